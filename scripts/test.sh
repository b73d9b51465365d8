#!/usr/bin/env bash
# Builds (release preset) and runs the whole test suite through CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -f build/release/build.ninja ]; then
  cmake --preset release
fi
cmake --build --preset release
ctest --preset release --timeout 600 -j "$(nproc)" "$@"
