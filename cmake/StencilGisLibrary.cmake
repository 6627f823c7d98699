# Common settings for every target of the project (one place, called by each folder).

set(STENCIL_GIS_WARNINGS -Wall -Wextra -Wpedantic -Wconversion -Wsign-conversion -Wshadow
    -Wnon-virtual-dtor -Wold-style-cast -Werror)

# Applies language level, warnings and precision guards to any target of ours.
function(stencil_gis_configure_target target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF POSITION_INDEPENDENT_CODE ON)
  target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:${STENCIL_GIS_WARNINGS}>)
  # dvec3 -> vec3 must be spelled out: never narrow a position by accident.
  target_compile_definitions(${target} PUBLIC GLM_FORCE_EXPLICIT_CTOR GLM_FORCE_XYZW_ONLY)
endfunction()

# stencil_gis_add_library(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates target gis_<name> with alias gis::<name>, public headers in <name>/include.
function(stencil_gis_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(target gis_${name})
  add_library(${target} STATIC ${ARG_SOURCES})
  add_library(gis::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  stencil_gis_configure_target(${target})
  target_include_directories(${target}
    PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
           $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  install(TARGETS ${target} EXPORT StencilGisTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()

# Exports gis::* so a GIS client can find_package(StencilGis).
function(stencil_gis_install_package)
  include(CMakePackageConfigHelpers)
  set(cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/StencilGis)
  install(EXPORT StencilGisTargets NAMESPACE gis:: DESTINATION ${cmake_dir})
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/StencilGisConfig.cmake.in
    ${PROJECT_BINARY_DIR}/StencilGisConfig.cmake INSTALL_DESTINATION ${cmake_dir})
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/StencilGisConfigVersion.cmake
    COMPATIBILITY SameMinorVersion)
  install(FILES ${PROJECT_BINARY_DIR}/StencilGisConfig.cmake
                ${PROJECT_BINARY_DIR}/StencilGisConfigVersion.cmake
                ${PROJECT_SOURCE_DIR}/cmake/FindGeographicLib.cmake
                ${PROJECT_SOURCE_DIR}/cmake/FixOpenImageIO.cmake
          DESTINATION ${cmake_dir})
endfunction()

# In sanitizer builds every executable gets the project's default sanitizer options and the
# LeakSanitizer suppressions for Mesa (cmake/sanitizer_defaults.cpp), so tests and programs
# need no environment variables.
function(stencil_gis_add_sanitizer_defaults target)
  if(STENCIL_GIS_SANITIZE)
    target_sources(${target} PRIVATE ${PROJECT_SOURCE_DIR}/cmake/sanitizer_defaults.cpp)
  endif()
endfunction()
