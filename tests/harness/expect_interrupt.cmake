# `sahbench run` stopped by SIGINT: exit 130, the message with the command that continues the run, and
# only whole rows in the CSV (here the first scene's one cell; the second scene's cell was in progress).
#   cmake -DSAHBENCH=path -DWORK=dir -P expect_interrupt.cmake
include(${CMAKE_CURRENT_LIST_DIR}/interrupt_after_first_row.cmake)
file(MAKE_DIRECTORY ${WORK})
set(config ${WORK}/interrupt.toml)
set(csv ${WORK}/interrupt.csv)
file(REMOVE ${csv})
file(WRITE ${config} "[experiment]
name = \"interrupt\"
output = \"${csv}\"
scenes = [\"proc:soup:tris=500\", \"proc:sphere:tris=4M\"]
reference = \"none\"
[repetitions]
build = 1
build_warmup = 0
trace = 30
trace_warmup = 0
[[builder]]
name = \"binned_sah\"
[[ray_set]]
kind = \"primary\"
width = 512
height = 512
")
# SIGINT once the first scene's row is on disk: the second scene, a 4M-triangle sphere traced 30 times,
# is then still running.
interrupt_after_first_row(${csv} rc err run ${config})
expect_interrupted(${rc} "${err}" "interrupted after 1 of 2 cells; continue with: sahbench run ${config} --resume")
file(STRINGS ${csv} lines)
list(LENGTH lines count)
if(NOT count EQUAL 2)
  message(FATAL_ERROR "${csv}: ${count} lines, expected the header and the first scene's row")
endif()
