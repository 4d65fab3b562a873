# Installing SwerveMPC as a package with components (find_package(SwerveMPC COMPONENTS ...)).
# Each component is one export set and one targets file, so a consumer loads, and needs the
# dependencies of, only the components it asks for (cmake/SwerveMPCConfig.cmake.in).
include(GNUInstallDirs)
set(SWERVE_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/SwerveMPC)

# swerve_install_component(<component> <target>...): installs the targets and their export file
# SwerveMPC_<component>Targets.cmake, and records the component as built.
function(swerve_install_component component)
  install(TARGETS ${ARGN} EXPORT SwerveMPC_${component}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(EXPORT SwerveMPC_${component} NAMESPACE SwerveMPC::
          FILE SwerveMPC_${component}Targets.cmake DESTINATION ${SWERVE_CMAKE_DIR})
  set_property(GLOBAL APPEND PROPERTY SWERVE_PACKAGE_COMPONENTS ${component})
endfunction()
