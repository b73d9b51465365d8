# cmake -DSTRATA_SOURCE_DIR=<repo> -P cmake/CheckModuleGraph.cmake: checks every module's includes
# against cmake/ModuleGraph.cmake (run by CTest as `ModuleGraph`, so an include added without
# reconfiguring is caught too).
cmake_minimum_required(VERSION 3.25)  # script mode: IN_LIST and current policies
include(${CMAKE_CURRENT_LIST_DIR}/ModuleGraph.cmake)
foreach(module IN LISTS STRATA_MODULES)
  strata_check_module_includes(${STRATA_SOURCE_DIR} ${module} "${STRATA_DEPS_${module}}")
endforeach()
message(STATUS "module graph: every include follows cmake/ModuleGraph.cmake")
