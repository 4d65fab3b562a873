# Runs the CLI and requires its standard output to equal a file in the source tree byte for byte: a
# generated document (docs/configuration-reference.md) that must not fall behind what generates it.
#   -DCOMMAND="exe|arg|..." -DEXPECTED=<file> -DACTUAL=<where to write the output> -DREGENERATE=<how>
string(REPLACE "|" ";" COMMAND "${COMMAND}")
execute_process(COMMAND ${COMMAND} RESULT_VARIABLE code OUTPUT_FILE ${ACTUAL} ERROR_VARIABLE err)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "the command failed (${code}):\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${ACTUAL} ${EXPECTED} RESULT_VARIABLE differ)
if(NOT differ EQUAL 0)
  message(FATAL_ERROR "${EXPECTED} is not what the command prints now (${ACTUAL}); regenerate it: ${REGENERATE}")
endif()
