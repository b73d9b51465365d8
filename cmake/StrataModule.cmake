# strata_add_module(name "deps"): one static library per folder src/<name>, public headers in
# include/strata/<name>. Sources are globbed (subfolders too: a format or codec may keep its own
# folder, src/io/<format>/) so a new file needs no CMake edit.
#
# `deps` is the module's own list of strata modules (cmake/ModuleGraph.cmake); each include of
# another module must be one of them, or configuring fails.
function(strata_add_module name deps)
  file(GLOB_RECURSE _sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/${name}/*.cpp)
  if(NOT _sources)
    return()
  endif()
  strata_check_module_includes(${PROJECT_SOURCE_DIR} ${name} "${deps}")
  list(TRANSFORM deps PREPEND strata_ OUTPUT_VARIABLE _dep_targets)
  add_library(strata_${name} STATIC ${_sources})
  target_include_directories(strata_${name} PUBLIC ${PROJECT_SOURCE_DIR}/include
                                             PRIVATE ${PROJECT_SOURCE_DIR}/src)
  target_link_libraries(strata_${name} PUBLIC ${_dep_targets} strata_options OpenMP::OpenMP_CXX
                        Threads::Threads nlohmann_json::nlohmann_json fmt::fmt)
  if(name STREQUAL "io")
    # turbojpeg: precomputed jpeg chunks; GDCM: DICOM series; zstd, blosc: Zarr chunks; HDF5;
    # curl: .strata files read from http(s) URLs (io/http_source)
    target_link_libraries(strata_${name} PRIVATE ZLIB::ZLIB TIFF::TIFF PkgConfig::TURBOJPEG gdcmMSFF PkgConfig::ZSTD
                                                 PkgConfig::BLOSC PkgConfig::HDF5 PkgConfig::CURL)
  endif()
  if(name MATCHES "^(tensor|ta|quant)$")
    target_link_libraries(strata_${name} PUBLIC Eigen3::Eigen)
  endif()
  if(name STREQUAL "store")  # store/zstd_frame.cpp: the container's zstd frames
    target_link_libraries(strata_${name} PRIVATE PkgConfig::ZSTD)
  endif()
  if(name STREQUAL "render")
    target_link_libraries(strata_${name} PRIVATE strata_spng PkgConfig::TURBOJPEG)
  endif()
  if(name STREQUAL "dist")  # MPI only here: the `strata` program never links it
    target_link_libraries(strata_${name} PUBLIC MPI::MPI_CXX)
  endif()
  if(name STREQUAL "server")
    target_link_libraries(strata_${name} PRIVATE ZLIB::ZLIB)  # gzip answers (src/server/http_wire.cpp)
    strata_embed_web(strata_${name})  # the viewer's files compiled in (cmake/EmbedWeb.cmake)
  endif()
endfunction()
