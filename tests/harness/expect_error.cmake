# Runs COMMAND (arguments separated by '|', since ctest would split a ';' list) and passes when it exits
# with EXIT_CODE and its stderr contains EXPECT: the CLI's contract for bad input.
#   cmake -DCOMMAND="prog|arg|..." -DEXIT_CODE=2 -DEXPECT="text" -P expect_error.cmake
string(REPLACE "|" ";" command "${COMMAND}")
execute_process(COMMAND ${command} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc STREQUAL EXIT_CODE)
  message(FATAL_ERROR "exit code ${rc}, expected ${EXIT_CODE}\nstdout: ${out}\nstderr: ${err}")
endif()
string(FIND "${err}" "${EXPECT}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "stderr lacks '${EXPECT}':\n${err}")
endif()
