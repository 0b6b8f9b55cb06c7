# A shard killed and resumed gives the same rows as the shard run straight through: `run --shard 1/2`
# stopped by SIGINT once its first row is on disk, continued with --resume, then compared with an
# uninterrupted run of the same shard (the same cells, and the same deterministic metrics).
#   cmake -DSAHBENCH=path -DWORK=dir -P expect_shard_resume.cmake
include(${CMAKE_CURRENT_LIST_DIR}/interrupt_after_first_row.cmake)
file(MAKE_DIRECTORY ${WORK})
set(config ${WORK}/shard_resume.toml)
set(csv ${WORK}/shard_resume-shard-1-of-2.csv)
set(straight ${WORK}/straight.csv)
file(REMOVE ${csv} ${straight})
# The plan gives sweep_sah on the large sphere to shard 0, and binned_sah on it with the small soup to
# shard 1: shard 1 writes the soup's rows at once, then works on the sphere for a while.
file(WRITE ${config} "[experiment]
name = \"shard_resume\"
output = \"${WORK}/shard_resume.csv\"
scenes = [\"proc:soup:tris=500\", \"proc:sphere:tris=2M\"]
reference = \"none\"
[repetitions]
build = 1
build_warmup = 0
trace = 10
trace_warmup = 0
interleave = false
[[builder]]
name = \"binned_sah\"
[[builder]]
name = \"sweep_sah\"
[[ray_set]]
kind = \"primary\"
width = 256
height = 256
")
interrupt_after_first_row(${csv} rc err run ${config} --shard 1/2)
expect_interrupted(${rc} "${err}" "continue with: sahbench run ${config} --resume --shard 1/2")
file(STRINGS ${csv} lines)
list(LENGTH lines interrupted_lines)
execute_process(COMMAND ${SAHBENCH} run ${config} --shard 1/2 --resume RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "resume: exit code ${rc}\n${err}")
endif()
execute_process(COMMAND ${SAHBENCH} run ${config} --shard 1/2 --output ${straight} RESULT_VARIABLE rc
                ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "straight run: exit code ${rc}\n${err}")
endif()
file(STRINGS ${csv} resumed)
file(STRINGS ${straight} whole)
list(LENGTH resumed n_resumed)
list(LENGTH whole n_whole)
if(NOT n_resumed EQUAL n_whole OR n_resumed LESS 3 OR NOT interrupted_lines LESS n_resumed)
  message(FATAL_ERROR "resumed shard has ${n_resumed} lines (${interrupted_lines} before the resume), the "
                      "straight run ${n_whole}; expected equal, and more than before the resume")
endif()
# compare requires each file's cells in the other, one run each, and equal deterministic metrics.
execute_process(COMMAND ${SAHBENCH} compare ${straight} ${csv} --deterministic-only RESULT_VARIABLE rc
                OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "0 missing \\(each a regression\\), 0 other regressions")
  message(FATAL_ERROR "resumed shard differs from the straight run (exit ${rc}):\n${out}\n${err}")
endif()
