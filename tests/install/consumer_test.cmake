# Installs the build tree into a fresh prefix, then configures, builds and runs examples/consumer
# against it with find_package(SwerveMPC): a broken export or a missing header fails this test.
#   -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DBUILD_TYPE=...
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
function(run_step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "step failed (${code}): ${ARGN}\n${out}\n${err}")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()
run_step(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
run_step(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/consumer
         -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=${BUILD_TYPE})
run_step(${CMAKE_COMMAND} --build ${WORK_DIR}/consumer)
# Three seconds of the closed loop with a replan every second (two land after the first plan).
run_step(${WORK_DIR}/consumer/swerve_consumer ${prefix}/share/swerve_mpc/configs 3)
if(NOT last_output MATCHES "SwerveMPC [0-9]+\\.[0-9]+\\.[0-9]+" OR
   NOT last_output MATCHES "closed loop: [0-9]+ steps, [12] replans, 0 safe stops, position RMSE")
  message(FATAL_ERROR "consumer printed:\n${last_output}")
endif()
message(STATUS "consumer output:\n${last_output}")
if(NOT EXISTS ${prefix}/bin/swerve-mpc)
  message(FATAL_ERROR "swerve-mpc was not installed into ${prefix}/bin")
endif()
