# interrupt_after_first_row(CSV RC_VAR ERR_VAR ARGS...): runs `${SAHBENCH} ARGS...` in the background and
# sends it SIGINT once CSV holds its header and a first row, so a test does not depend on the machine's
# speed; sets RC_VAR to the run's exit status and ERR_VAR to its stderr (kept in CSV.err).
function(interrupt_after_first_row csv rc_var err_var)
  execute_process(
    COMMAND bash -c "\"$0\" \"$@\" 2>\"${csv}.err\" & pid=$!
                     for i in $(seq 1 1200); do
                       [ \"$(wc -l < \"${csv}\" 2>/dev/null || echo 0)\" -ge 2 ] && break; sleep 0.1
                     done
                     kill -INT $pid; wait $pid; echo $?"
            ${SAHBENCH} ${ARGN}
    OUTPUT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE)
  file(READ ${csv}.err err)
  set(${rc_var} "${rc}" PARENT_SCOPE)
  set(${err_var} "${err}" PARENT_SCOPE)
endfunction()

# expect_interrupted(RC ERR TEXT): fails the test unless the run exited 130 (stopped by SIGINT) and its stderr
# ERR holds TEXT (the interrupt message with the command that continues it).
function(expect_interrupted rc err text)
  if(NOT rc EQUAL 130)
    message(FATAL_ERROR "exit code ${rc}, expected 130\nstderr: ${err}")
  endif()
  string(FIND "${err}" "${text}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "stderr lacks '${text}':\n${err}")
  endif()
endfunction()
