#!/usr/bin/env bash
# Installs every Debian package Strata uses, then configures and builds the release preset.
# Idempotent: on a machine that is already set up it only runs an incremental build.
#   ./setup.sh           the library, CLI, tests and benchmarks
#   ./setup.sh --bench   also the opt-in rate-distortion comparison with zfp (bench/rd)
#   ./setup.sh --fuzz    also clang with libFuzzer and the sanitizer runtimes, for the fuzz
#                        targets (scripts/fuzz.sh, docs/reliability.md; CI passes it)
set -euo pipefail
cd "$(dirname "$0")"

PACKAGES=(
  cmake ninja-build g++ pkg-config            # build
  libeigen3-dev                               # linear algebra
  zlib1g-dev libzstd-dev                      # gzip (NRRD, .nii.gz), zstd
  libtiff-dev                                 # TIFF stacks
  libgdcm-dev                                 # DICOM series (src/io/dicom)
  python3-pydicom                             # reference DICOM writer (python/tests/test_dicom.py)
  libblosc-dev                                # blosc-compressed Zarr chunks (OME-Zarr)
  libspng-dev libturbojpeg0-dev               # PNG output, JPEG frames of the viewer and precomputed chunks
  libcpp-httplib-dev                          # HTTP client of the server tests
  libcli11-dev nlohmann-json3-dev libfmt-dev  # CLI, JSON, formatting
  libgtest-dev libbenchmark-dev               # tests and benchmarks
  mricron-data                                # sample MRI and brain atlases
  python3-nibabel                             # reference NIfTI reader and its test files (tests/io)
  python3-mrcfile                             # reference MRC reader and writer (python/tests/test_mrc.py)
  python3-meshio                              # reads Strata's legacy .vtk output (python/tests/test_vtk.py)
  python3-pil                                 # reference JPEG encoder of python/tests/test_precomputed.py
  python3-zarr python3-numcodecs              # reference Zarr reader and writer (python/tests/test_zarr.py)
  python3-dask python3-xarray                 # opened .strata files as dask/xarray arrays (test_geometry.py)
  python3-aiohttp                             # zarr-python reading strata serve over HTTP (test_served_views.py)
  libhdf5-dev                                 # HDF5 files (src/io/hdf5.cpp), the C library
  libcurl4-openssl-dev                        # .strata files read from http(s) URLs (src/io/http_source.cpp)
  python3-h5py                                # reference HDF5 reader and writer (python/tests/test_hdf5.py)
  chromium                                    # browser tests of the viewer (tests/web)
  libopenmpi-dev openmpi-bin                  # strata-mpi, distributed compression (ctest -L mpi)
  # The Python module `import strata` (python/, docs/python.md), built by the same CMake build for
  # Debian's /usr/bin/python3: pybind11 and the interpreter's headers to build it, numpy for its
  # arrays, pytest for its tests (ctest -L python).
  python3-pybind11 python3-dev python3-numpy python3-pytest
)
BENCH_PACKAGES=(zfp python3-numpy python3-matplotlib python3-pil)  # bench/ only (--bench); never the library
# fuzz/ only (--fuzz): clang 14 (clang, clang++), libFuzzer + ASan/UBSan runtimes (only
# recommended by clang-14, so named here) and LLVM's OpenMP runtime for clang's -fopenmp.
# About 45 MB to download, 250 MB installed.
FUZZ_PACKAGES=(clang libclang-rt-14-dev libomp-dev)

for arg in "$@"; do
  case "$arg" in
    --bench) PACKAGES+=("${BENCH_PACKAGES[@]}") ;;
    --fuzz) PACKAGES+=("${FUZZ_PACKAGES[@]}") ;;
    *) echo "usage: $0 [--bench] [--fuzz]" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# playwright-core for the browser tests, from tests/web/package-lock.json; only when
# node_modules is missing or older than the lock file.
if [ ! -f tests/web/node_modules/.package-lock.json ] ||
   [ tests/web/package-lock.json -nt tests/web/node_modules/.package-lock.json ]; then
  if command -v npm >/dev/null; then
    echo "setup: installing the browser tests' npm packages (tests/web)"
    npm ci --prefix tests/web --no-audit --no-fund --loglevel=error
  else
    echo "setup: npm not found; the browser tests (ctest -L web) will say what is missing" >&2
  fi
fi

# Neuroglancer and vite for the Neuroglancer acceptance test, from tests/ng/package-lock.json
# (same rule), and its bundle (tests/ng/dist).
if [ ! -f tests/ng/node_modules/.package-lock.json ] ||
   [ tests/ng/package-lock.json -nt tests/ng/node_modules/.package-lock.json ]; then
  if command -v npm >/dev/null; then
    echo "setup: installing the Neuroglancer test's npm packages (tests/ng)"
    npm ci --prefix tests/ng --no-audit --no-fund --loglevel=error
    npm run --prefix tests/ng --silent build
  else
    echo "setup: npm not found; the Neuroglancer test (ctest -R WebNeuroglancer) will be skipped" >&2
  fi
fi

if [ ! -f build/release/build.ninja ]; then
  cmake --preset release
fi
cmake --build --preset release
