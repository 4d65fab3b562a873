# Runs a scenario with the CLI (under the emulator in a cross build) and compares its summary.json
# with a reference summary (scripts/compare_summary.py): the same results on every architecture.
#   -DCOMMAND="exe|arg|..." -DOUT_DIR=... -DPYTHON=... -DCOMPARE=... -DREFERENCE=...
string(REPLACE "|" ";" COMMAND "${COMMAND}")
file(REMOVE_RECURSE ${OUT_DIR})
execute_process(COMMAND ${COMMAND} --out ${OUT_DIR} --quiet RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "the run failed (${code}):\n${out}\n${err}")
endif()
execute_process(COMMAND ${PYTHON} ${COMPARE} ${OUT_DIR}/summary.json ${REFERENCE}
                RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "${err}")
endif()
message(STATUS "${out}")
