# Every dependency is a Debian package installed by ./setup.sh (see docs/architecture.md).
find_package(Threads REQUIRED)
find_package(OpenMP REQUIRED)
find_package(ZLIB REQUIRED)
find_package(TIFF REQUIRED)
# DICOM series (src/io/dicom): Debian's libgdcm-dev installs its CMake package under gdcm-3.0; only
# the imported targets gdcmMSFF (images, readers) and its dependencies are used.
find_package(GDCM REQUIRED NO_MODULE PATHS /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/gdcm-3.0)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(nlohmann_json 3 REQUIRED)
find_package(fmt REQUIRED)
find_package(CLI11 REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(ZSTD REQUIRED IMPORTED_TARGET libzstd)
pkg_check_modules(BLOSC REQUIRED IMPORTED_TARGET blosc)  # Zarr chunks (io/zarr)
pkg_check_modules(TURBOJPEG REQUIRED IMPORTED_TARGET libturbojpeg)  # JPEG frames of the viewer (render), precomputed jpeg chunks (io)
# HDF5's C library, Debian's serial build (libhdf5-dev): the HDF5 reader and writer of io only.
pkg_check_modules(HDF5 REQUIRED IMPORTED_TARGET hdf5-serial)
# libcurl (Debian's OpenSSL flavour, libcurl4-openssl-dev): HTTP range requests for .strata files
# read from http(s) URLs (src/io/http_source.cpp only).
pkg_check_modules(CURL REQUIRED IMPORTED_TARGET libcurl)
# Debian builds cpp-httplib as a library with OpenSSL, zlib and brotli support: its pkg-config
# flags (-DCPPHTTPLIB_*_SUPPORT) must reach every file that includes httplib.h, or the class
# layouts differ from the library's. Only the server tests' HTTP clients use it (the server
# speaks HTTP itself: src/server/http_server.cpp).
pkg_check_modules(HTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib)

# libspng ships neither a CMake nor a pkg-config file: find it by hand.
find_path(SPNG_INCLUDE_DIR spng.h REQUIRED)
find_library(SPNG_LIBRARY spng REQUIRED)
add_library(strata_spng INTERFACE)
target_include_directories(strata_spng INTERFACE ${SPNG_INCLUDE_DIR})
target_link_libraries(strata_spng INTERFACE ${SPNG_LIBRARY})

add_library(strata_options INTERFACE)
# Every closed list (payload kinds, decoders, ISAs, formats...) is an enum whose switches must
# name each value: a missing case is an error, not a warning that scrolls by.
target_compile_options(strata_options INTERFACE -Wall -Wextra -Werror=switch)
if(STRATA_NATIVE)
  target_compile_options(strata_options INTERFACE -march=native)
endif()
if(STRATA_SANITIZE)
  target_compile_options(strata_options INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer)
  target_link_options(strata_options INTERFACE -fsanitize=address,undefined)
endif()
