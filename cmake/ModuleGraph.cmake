# The module graph, in one place: every library module with the modules it uses directly
# (docs/architecture.md draws it). The build and the test `ModuleGraph` check every include
# against it (cmake/CheckModuleGraph.cmake). `gen` is used only by the apps, tests and benchmarks.
# `dist` (MPI) is built only when MPI is found, and only `strata-mpi` links it (apps/strata-mpi).
set(STRATA_MODULES core io gen tensor quant store ta mixture lod render server dist)
set(STRATA_DEPS_core "")
set(STRATA_DEPS_io core)
set(STRATA_DEPS_gen core io)
set(STRATA_DEPS_tensor core)
set(STRATA_DEPS_quant core tensor)
set(STRATA_DEPS_store core io)
set(STRATA_DEPS_ta core io tensor quant store)
set(STRATA_DEPS_mixture core io quant store)
set(STRATA_DEPS_lod core tensor quant store ta)
set(STRATA_DEPS_render core io store ta mixture lod)
set(STRATA_DEPS_server core io store ta mixture lod render)
set(STRATA_DEPS_dist core io store ta mixture)

# Fails with the file and the include when a module includes a module it does not depend on.
function(strata_check_module_includes source_dir name deps)
  file(GLOB_RECURSE _files ${source_dir}/src/${name}/*.cpp ${source_dir}/src/${name}/*.hpp
       ${source_dir}/include/strata/${name}/*.hpp)
  foreach(file IN LISTS _files)
    file(STRINGS ${file} _includes REGEX "^#include \"(strata/)?[a-z_]+/")
    foreach(line IN LISTS _includes)
      string(REGEX REPLACE "^#include \"(strata/)?([a-z_]+)/.*" "\\2" _used "${line}")
      if(NOT _used STREQUAL name AND NOT _used IN_LIST deps)
        file(RELATIVE_PATH _rel ${source_dir} ${file})
        message(FATAL_ERROR "module graph: ${_rel} includes module '${_used}' (${line}), but module '${name}' "
                            "depends only on: ${deps}. Add the edge in cmake/ModuleGraph.cmake (and "
                            "docs/architecture.md) or move the code.")
      endif()
    endforeach()
  endforeach()
endfunction()
