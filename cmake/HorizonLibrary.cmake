# libhorizon as a C programmer links it: one static (libhorizon.a) and one
# shared (libhorizon.so) library made of every module's objects, installed by
# `cmake --install` with the public headers, a pkg-config file (horizon.pc) and
# a CMake package config (find_package(horizon) -> horizon::horizon).
set(HZ_MODULES hz_core hz_scene hz_io hz_terrain hz_foliage hz_fx hz_render)
set(HZ_OBJECTS)
foreach(m ${HZ_MODULES})
  set_target_properties(${m} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  list(APPEND HZ_OBJECTS $<TARGET_OBJECTS:${m}>)
endforeach()

add_library(horizon_shared SHARED ${HZ_OBJECTS})
add_library(horizon_static STATIC ${HZ_OBJECTS})
foreach(t horizon_shared horizon_static)
  set_target_properties(${t} PROPERTIES OUTPUT_NAME horizon)
  target_include_directories(${t} PUBLIC $<BUILD_INTERFACE:${HZ_INCLUDE}> $<INSTALL_INTERFACE:include>)
endforeach()
set_target_properties(horizon_shared PROPERTIES VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR})
# The modules' own dependencies (GDAL, epoxy, EGL, GLFW, libpng, assimp,
# meshoptimizer ...): linking the module archives after their objects pulls
# no member twice (every symbol is already defined) but brings their
# transitive link interfaces.
target_link_libraries(horizon_shared PRIVATE ${HZ_MODULES})
target_link_libraries(horizon_shared PUBLIC PkgConfig::CGLM)

include(GNUInstallDirs)
install(TARGETS horizon_shared horizon_static
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${HZ_INCLUDE}/horizon DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
configure_file(${CMAKE_CURRENT_LIST_DIR}/horizon.pc.in ${CMAKE_BINARY_DIR}/horizon.pc @ONLY)
install(FILES ${CMAKE_BINARY_DIR}/horizon.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
include(CMakePackageConfigHelpers)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/horizonConfig.cmake.in
                              ${CMAKE_BINARY_DIR}/horizonConfig.cmake
                              INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/horizon
                              PATH_VARS CMAKE_INSTALL_INCLUDEDIR CMAKE_INSTALL_LIBDIR)
write_basic_package_version_file(${CMAKE_BINARY_DIR}/horizonConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/horizonConfig.cmake ${CMAKE_BINARY_DIR}/horizonConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/horizon)
