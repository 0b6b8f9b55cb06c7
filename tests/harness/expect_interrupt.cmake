# `sahbench run` stopped by SIGINT: exit 130, the message with the command that continues the run, and
# only whole rows in the CSV (here the first scene's one cell; the second scene's cell was in progress).
#   cmake -DSAHBENCH=path -DWORK=dir -P expect_interrupt.cmake
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
execute_process(COMMAND timeout --preserve-status -s INT 4 ${SAHBENCH} run ${config}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 130)
  message(FATAL_ERROR "exit code ${rc}, expected 130\nstderr: ${err}")
endif()
string(FIND "${err}" "interrupted after 1 of 2 cells; continue with: sahbench run ${config} --resume" at)
if(at EQUAL -1)
  message(FATAL_ERROR "stderr lacks the interrupt message:\n${err}")
endif()
file(STRINGS ${csv} lines)
list(LENGTH lines count)
if(NOT count EQUAL 2)
  message(FATAL_ERROR "${csv}: ${count} lines, expected the header and the first scene's row")
endif()
