# Finds what the Python module needs and sets STRATA_PYTHON_FOUND: Debian's interpreter with its
# headers (python3-dev) and pybind11 (python3-pybind11). Included from the top-level
# CMakeLists.txt before the library modules are added, because finding them switches those to
# position-independent code.
#
# The interpreter defaults to /usr/bin/python3: Debian's python3-numpy and python3-pytest are
# installed for it, while a `python3` earlier on PATH (pyenv, a virtualenv) may lack them.
# -DPython3_EXECUTABLE=... picks another one; the module is built for that interpreter and the
# CTest tests run with it.
set(STRATA_PYTHON_FOUND OFF)
if(STRATA_SANITIZE)
  # An ASan-instrumented extension only loads into an interpreter started with the ASan runtime
  # preloaded; the sanitizer builds test the library through the C++ suite instead.
  message(STATUS "Python module: skipped in sanitizer builds (STRATA_SANITIZE)")
  return()
endif()
if(NOT DEFINED Python3_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python3_EXECUTABLE /usr/bin/python3 CACHE FILEPATH "Interpreter the Python module is built and tested for")
endif()
find_package(Python3 COMPONENTS Interpreter Development.Module QUIET)
if(NOT Python3_FOUND)
  message(STATUS "Python module: skipped, no Python 3 interpreter with development headers "
                 "(install python3-dev, or configure with -DSTRATA_BUILD_PYTHON=OFF to silence this)")
  return()
endif()
# Debian installs pybind11's CMake package under /usr/lib/cmake (pybind11-dev); a pip-installed
# pybind11 says where its own is.
execute_process(COMMAND ${Python3_EXECUTABLE} -c "import pybind11; print(pybind11.get_cmake_dir())"
                OUTPUT_VARIABLE _pybind11_dir OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
find_package(pybind11 2.6 CONFIG QUIET HINTS ${_pybind11_dir})
if(NOT pybind11_FOUND)
  message(STATUS "Python module: skipped, pybind11 not found (install python3-pybind11, as ./setup.sh does, "
                 "or configure with -DSTRATA_BUILD_PYTHON=OFF to silence this)")
  return()
endif()
message(STATUS "Python module: pybind11 ${pybind11_VERSION} for ${Python3_EXECUTABLE} (${Python3_VERSION})")
set(STRATA_PYTHON_FOUND ON)
