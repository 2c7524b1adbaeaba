# `cmake --install` and find_package(mlspaces CONFIG).
#
# Installs the public headers, one library per layer (static; shared with
# -DBUILD_SHARED_LIBS=ON), the `mlspaces` command, the bundled robots (share/mlspaces/robots)
# and a CMake package in lib/cmake/mlspaces:
#
#   find_package(mlspaces 0.1 CONFIG REQUIRED)            # or COMPONENTS core library ...
#   target_link_libraries(app PRIVATE mlspaces::mlspaces)  # every layer that was built
#   target_link_libraries(app PRIVATE mlspaces::library)   # or one layer (and what it needs)
#
# Targets: mlspaces::core, ::library, ::resources, ::sim, ::robots, ::graspgen, ::datagen (the
# last four when
# MLSPACES_BUILD_SIM), the umbrella ::mlspaces and the command ::cli. The package finds the
# dependencies the layers link (mlspacesConfig.cmake.in) and MuJoCo the way this build did
# (cmake/FindMuJoCo.cmake, installed beside it; MUJOCO_DIR overrides).
include(CMakePackageConfigHelpers)

set(MLSPACES_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/mlspaces")
set(_mlspaces_layers core library resources)
if(TARGET mlspaces_sim)
  list(APPEND _mlspaces_layers sim robots graspgen datagen)
endif()

add_library(mlspaces_all INTERFACE)
set_target_properties(mlspaces_all PROPERTIES EXPORT_NAME mlspaces)
add_library(mlspaces::mlspaces ALIAS mlspaces_all)
set(_mlspaces_targets mlspaces_all)
foreach(layer ${_mlspaces_layers})
  set_target_properties(mlspaces_${layer} PROPERTIES EXPORT_NAME ${layer})
  add_library(mlspaces::${layer} ALIAS mlspaces_${layer})
  target_link_libraries(mlspaces_all INTERFACE mlspaces_${layer})
  list(APPEND _mlspaces_targets mlspaces_${layer})
endforeach()
set_target_properties(mlspaces PROPERTIES EXPORT_NAME cli)
# A wheel (pip install .) holds the Python package only: python/CMakeLists.txt installs it.
if(SKBUILD)
  return()
endif()

install(TARGETS ${_mlspaces_targets} mlspaces
  EXPORT mlspacesTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY include/mlspaces DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY assets/robots DESTINATION ${CMAKE_INSTALL_DATADIR}/mlspaces)
install(EXPORT mlspacesTargets NAMESPACE mlspaces:: DESTINATION ${MLSPACES_INSTALL_CMAKEDIR})

# What the config needs to know about this build.
set(MLSPACES_PACKAGE_LAYERS "${_mlspaces_layers}")
if(TARGET mlspaces_sim)
  get_filename_component(MLSPACES_PACKAGE_MUJOCO_DIR "${MuJoCo_INCLUDE_DIR}" DIRECTORY)
else()
  set(MLSPACES_PACKAGE_MUJOCO_DIR "")
endif()
configure_package_config_file(cmake/mlspacesConfig.cmake.in
  "${PROJECT_BINARY_DIR}/mlspacesConfig.cmake"
  INSTALL_DESTINATION ${MLSPACES_INSTALL_CMAKEDIR})
write_basic_package_version_file("${PROJECT_BINARY_DIR}/mlspacesConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/mlspacesConfig.cmake"
              "${PROJECT_BINARY_DIR}/mlspacesConfigVersion.cmake"
              cmake/FindMuJoCo.cmake
        DESTINATION ${MLSPACES_INSTALL_CMAKEDIR})
