# Runs the CLI twice with the same arguments into two output directories and requires byte-identical
# per-step logs: a run whose deadlines are kept on a work clock (--work-clock) does the same work
# every time, whatever the machine's load.
#   -DCOMMAND="exe|arg|..." -DOUT_DIR=... -DLOG=<csv file name>
string(REPLACE "|" ";" COMMAND "${COMMAND}")
file(REMOVE_RECURSE ${OUT_DIR})
foreach(run IN ITEMS first second)
  execute_process(COMMAND ${COMMAND} --out ${OUT_DIR}/${run} --quiet RESULT_VARIABLE code OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "the ${run} run failed (${code}):\n${out}\n${err}")
  endif()
endforeach()
if(NOT out MATCHES "deadlines and timings are on a work clock")
  message(FATAL_ERROR "the run did not say it used a work clock:\n${out}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT_DIR}/first/${LOG} ${OUT_DIR}/second/${LOG}
                RESULT_VARIABLE differ)
if(NOT differ EQUAL 0)
  message(FATAL_ERROR "two runs on the same work clock wrote different logs: ${OUT_DIR}/first/${LOG} and "
                      "${OUT_DIR}/second/${LOG}")
endif()
