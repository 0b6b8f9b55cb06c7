# `sahbench stress` stopped by SIGINT: exit 130 between cases, how many were done, and where their rows are.
#   cmake -DSAHBENCH=path -DWORK=dir -P expect_stress_interrupt.cmake
include(${CMAKE_CURRENT_LIST_DIR}/interrupt_after_first_row.cmake)
file(MAKE_DIRECTORY ${WORK})
set(config ${WORK}/stress_interrupt.toml)
set(csv ${WORK}/stress_interrupt.csv)
file(REMOVE ${csv})
file(WRITE ${config} "[stress]
name = \"stress_interrupt\"
output = \"${csv}\"
rays = 2000
trace_reps = 3
[[case]]
name = \"first\"
kind = \"sphere\"
size = 1280
[[case]]
name = \"second\"
kind = \"sphere\"
size = 1280
[[case]]
name = \"third\"
kind = \"sphere\"
size = 1280
")
# SIGINT once the first case's first row is on disk: the run finishes that case and stops before the next.
interrupt_after_first_row(${csv} rc err stress ${config})
expect_interrupted(${rc} "${err}" "interrupted after 1 of 3 cases; continue with: sahbench stress ${config}")
string(FIND "${err}" "[2/3]" second)
if(NOT second EQUAL -1)
  message(FATAL_ERROR "the second case started after the interrupt:\n${err}")
endif()
