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

# Installs `target` as component `name` of the package: its own export set, and what it needs
# (other components, imported targets) recorded for StencilGisConfig.cmake, so that
# find_package(StencilGis COMPONENTS ...) finds only what the asked components need.
function(stencil_gis_export_component name target deps)
  set(components "")
  set(imported "")
  foreach(dep IN LISTS deps)
    if(dep MATCHES "^gis::(.+)$")
      list(APPEND components ${CMAKE_MATCH_1})
    else()
      list(APPEND imported ${dep})
    endif()
  endforeach()
  set_property(GLOBAL APPEND PROPERTY STENCIL_GIS_COMPONENTS ${name})
  set_property(GLOBAL PROPERTY STENCIL_GIS_COMPONENT_${name}_COMPONENTS "${components}")
  set_property(GLOBAL PROPERTY STENCIL_GIS_COMPONENT_${name}_IMPORTED "${imported}")
  install(TARGETS ${target} EXPORT StencilGis_${name}
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
endfunction()

# stencil_gis_add_library(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates target gis_<name> with alias gis::<name>, public headers in <name>/include, installed
# as package component <name>.
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
  # A static library's private dependencies are link dependencies of its users: they count.
  stencil_gis_export_component(${name} ${target} "${ARG_PUBLIC_DEPS};${ARG_PRIVATE_DEPS}")
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()

# The package a client's find_dependency() call needs for one of our imported dependencies.
function(stencil_gis_package_of imported out)
  set(packages
    "Threads::Threads=Threads" "glm::glm=glm" "PkgConfig::EPOXY=epoxy" "glfw=glfw3"
    "OpenImageIO::OpenImageIO=OpenImageIO" "GDAL::GDAL=GDAL" "GeographicLib::GeographicLib=GeographicLib"
    "nlohmann_json::nlohmann_json=nlohmann_json" "CGAL::CGAL=CGAL")
  foreach(entry IN LISTS packages)
    string(REPLACE "=" ";" pair "${entry}")
    list(GET pair 0 target)
    list(GET pair 1 package)
    if(target STREQUAL imported)
      set(${out} ${package} PARENT_SCOPE)
      return()
    endif()
  endforeach()
  message(FATAL_ERROR "stencil_gis_package_of: no package known for ${imported}; add it to cmake/StencilGisLibrary.cmake")
endfunction()

# Exports gis::* so a GIS client can find_package(StencilGis [COMPONENTS ...]): one targets file
# per component, and in the config the components and packages each one needs.
function(stencil_gis_install_package)
  include(CMakePackageConfigHelpers)
  set(cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/StencilGis)
  get_property(components GLOBAL PROPERTY STENCIL_GIS_COMPONENTS)
  set(table "")
  foreach(component IN LISTS components)
    install(EXPORT StencilGis_${component} NAMESPACE gis:: DESTINATION ${cmake_dir}
            FILE StencilGis_${component}Targets.cmake)
    get_property(needs GLOBAL PROPERTY STENCIL_GIS_COMPONENT_${component}_COMPONENTS)
    get_property(imported GLOBAL PROPERTY STENCIL_GIS_COMPONENT_${component}_IMPORTED)
    set(packages "")
    foreach(i IN LISTS imported)
      stencil_gis_package_of(${i} package)
      list(APPEND packages ${package})
    endforeach()
    list(REMOVE_DUPLICATES packages)
    string(APPEND table "set(_StencilGis_${component}_components \"${needs}\")\n")
    string(APPEND table "set(_StencilGis_${component}_packages \"${packages}\")\n")
  endforeach()
  set(STENCIL_GIS_COMPONENT_LIST "${components}")
  set(STENCIL_GIS_COMPONENT_TABLE "${table}")
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
