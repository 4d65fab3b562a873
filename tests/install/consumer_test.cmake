# Out-of-tree use of an installed SwerveMPC, one step per MODE:
#   install            install the build tree into WORK_DIR/prefix (the fixture of the others)
#   consumer           examples/consumer: the full package, a closed loop with a planner thread
#   kinematics_only    examples/kinematics_only: COMPONENTS kinematics, with every dependency but
#                      Eigen made unfindable, so a component that pulled in more fails here
#   sa_only            COMPONENTS sa configures with NLopt, Ipopt, Ceres and nlohmann-json unfindable,
#                      and loads the SA backend and what it builds on, not the other backends
#   controllers_only   examples/controllers_only: COMPONENTS controllers with Ceres, NLopt, Ipopt and
#                      nlohmann-json unfindable: make_controller with sa closes the loop, and a file
#                      naming nlopt is refused saying what to link
#   unknown_component  COMPONENTS nonsense must fail to configure and name the component
#   python_clean       the installed Python module imports in a clean interpreter (no environment,
#                      no PYTHONPATH) through the .pth the install wrote (into WORK_DIR/site here,
#                      rather than the machine's site folder)
#   -DMODE=... -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DBUILD_TYPE=...
set(prefix ${WORK_DIR}/prefix)
function(run_step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "step failed (${code}): ${ARGN}\n${out}\n${err}")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()
# build_example(<name> [cmake args...]): configures and builds examples/<name> against the
# installed prefix, in a fresh WORK_DIR/<name>.
function(build_example name)
  set(build ${WORK_DIR}/${name})
  file(REMOVE_RECURSE ${build})
  run_step(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/${name} -B ${build}
           -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=${BUILD_TYPE} ${ARGN})
  run_step(${CMAKE_COMMAND} --build ${build})
endfunction()
# unfindable(<package>...): sets `unfindable` to the -D flags under which find_package fails for them.
function(unfindable)
  set(flags "")
  foreach(package ${ARGN})
    list(APPEND flags -DCMAKE_DISABLE_FIND_PACKAGE_${package}=ON)
  endforeach()
  set(unfindable ${flags} PARENT_SCOPE)
endfunction()

if(MODE STREQUAL "install")
  file(REMOVE_RECURSE ${WORK_DIR})
  # The Python module's .pth goes to a folder of the test's own, not the machine's site-packages.
  run_step(${CMAKE_COMMAND} -E env SWERVE_PYTHON_PTH_DIR=${WORK_DIR}/site
           ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
  if(NOT EXISTS ${prefix}/bin/swerve-mpc)
    message(FATAL_ERROR "swerve-mpc was not installed into ${prefix}/bin")
  endif()

elseif(MODE STREQUAL "consumer")
  build_example(consumer)
  # Three seconds of the closed loop with a replan every second (two land after the first plan).
  run_step(${WORK_DIR}/consumer/swerve_consumer ${prefix}/share/swerve_mpc/configs 3)
  if(NOT last_output MATCHES "SwerveMPC [0-9]+\\.[0-9]+\\.[0-9]+" OR
     NOT last_output MATCHES "closed loop: [0-9]+ steps, [12] replans, 0 safe stops, position RMSE")
    message(FATAL_ERROR "consumer printed:\n${last_output}")
  endif()
  message(STATUS "consumer output:\n${last_output}")

elseif(MODE STREQUAL "kinematics_only")
  unfindable(yaml-cpp Ceres NLopt PkgConfig nlohmann_json)
  build_example(kinematics_only ${unfindable})
  # The program checks its own odometry against the commanded motion and exits non-zero if not.
  run_step(${WORK_DIR}/kinematics_only/swerve_kinematics_only)
  if(NOT last_output MATCHES "kinematics only: pose after 4 s")
    message(FATAL_ERROR "kinematics_only printed:\n${last_output}")
  endif()
  message(STATUS "kinematics_only output:\n${last_output}")

elseif(MODE STREQUAL "controllers_only")
  unfindable(Ceres NLopt PkgConfig nlohmann_json)
  build_example(controllers_only ${unfindable})
  run_step(${WORK_DIR}/controllers_only/swerve_controllers_only ${prefix}/share/swerve_mpc/configs)
  if(NOT last_output MATCHES "controllers only: [0-9]+ steps, [1-9][0-9]* from the optimiser" OR
     NOT last_output MATCHES "nlopt: .*link SwerveMPC::solvers")
    message(FATAL_ERROR "controllers_only printed:\n${last_output}")
  endif()
  message(STATUS "controllers_only output:\n${last_output}")

elseif(MODE STREQUAL "sa_only")
  set(source ${WORK_DIR}/sa_only)
  file(REMOVE_RECURSE ${source})
  file(WRITE ${source}/CMakeLists.txt
       "cmake_minimum_required(VERSION 3.20)\nproject(sa_only LANGUAGES CXX)\n"
       "find_package(SwerveMPC REQUIRED COMPONENTS sa)\n"
       "if(NOT TARGET SwerveMPC::solver_sa OR NOT TARGET SwerveMPC::swerve OR TARGET SwerveMPC::solver_nlopt)\n"
       "  message(FATAL_ERROR \"COMPONENTS sa loaded the wrong targets\")\n"
       "endif()\n")
  unfindable(Ceres NLopt PkgConfig nlohmann_json)
  run_step(${CMAKE_COMMAND} -S ${source} -B ${source}/build -DCMAKE_PREFIX_PATH=${prefix} ${unfindable})

elseif(MODE STREQUAL "unknown_component")
  set(source ${WORK_DIR}/unknown_component)
  file(REMOVE_RECURSE ${source})
  file(WRITE ${source}/CMakeLists.txt
       "cmake_minimum_required(VERSION 3.20)\nproject(unknown LANGUAGES CXX)\n"
       "find_package(SwerveMPC REQUIRED COMPONENTS kinematics warp_drive)\n")
  execute_process(COMMAND ${CMAKE_COMMAND} -S ${source} -B ${source}/build -DCMAKE_PREFIX_PATH=${prefix}
                  RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(code EQUAL 0 OR NOT err MATCHES "SwerveMPC has no component 'warp_drive'")
    message(FATAL_ERROR "expected a configure error naming 'warp_drive', got (${code}):\n${out}\n${err}")
  endif()

elseif(MODE STREQUAL "python_clean")
  file(STRINGS ${WORK_DIR}/site/swervempc.pth registered)
  if(NOT registered MATCHES "^${prefix}/.*dist-packages$")
    message(FATAL_ERROR "swervempc.pth names '${registered}', not a folder under ${prefix}")
  endif()
  # -I: no PYTHON* variables, no user site; -S then site.addsitedir: the site folder read exactly as
  # the interpreter reads its own at start-up (.pth files included). SWERVE_TEST_PYTHON: the interpreter.
  run_step(env -i $ENV{SWERVE_TEST_PYTHON} -I -S -c
           # (newlines, not semicolons: run_step's arguments are a CMake list)
           "import site\nsite.addsitedir('${WORK_DIR}/site')\nimport swervempc as sm\nprint('swervempc', sm.__version__, sm.Kinematics)")
  if(NOT last_output MATCHES "swervempc [0-9]+\\.[0-9]+\\.[0-9]+")
    message(FATAL_ERROR "python_clean printed:\n${last_output}")
  endif()

else()
  message(FATAL_ERROR "consumer_test.cmake: unknown MODE '${MODE}'")
endif()
