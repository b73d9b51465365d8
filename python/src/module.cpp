// The extension module strata._strata: the exception types, thread control, and the functions
// and classes of each binding file. The package strata (python/strata/__init__.py) re-exports
// them; docs/python.md is the user's guide.
#include <filesystem>
#include <new>
#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::python {

namespace {

// strata.Error (a RuntimeError), strata.FormatError (an Error) and strata.ParameterError (an
// Error and a ValueError): the library's exception classes, with their messages unchanged.
PyObject* g_error = nullptr;
PyObject* g_format_error = nullptr;
PyObject* g_parameter_error = nullptr;

PyObject* new_exception(py::module_& m, const char* name, PyObject* bases, const char* doc) {
  const std::string qualified = std::string("strata.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases, nullptr);
  if (!type) throw py::error_already_set();
  m.add_object(name, py::reinterpret_borrow<py::object>(type));
  return type;
}

void register_errors(py::module_& m) {
  g_error = new_exception(m, "Error", PyExc_RuntimeError,
                          "Raised for everything the Strata library reports: unreadable or malformed files, "
                          "inputs a codec cannot take, failed writes. The message names the file and the field.");
  g_format_error = new_exception(m, "FormatError", g_error,
                                 "A malformed or inconsistent input file: \"<file>: <field>: <problem>\".");
  const py::tuple bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError));
  g_parameter_error = new_exception(m, "ParameterError", bases.ptr(),
                                    "A value passed to the library is out of range: \"<parameter>: <problem>\" "
                                    "(also a ValueError).");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const OutOfMemoryError& e) {
      PyErr_SetString(PyExc_MemoryError, e.what());
    } catch (const ParameterError& e) {
      PyErr_SetString(g_parameter_error, e.what());
    } catch (const FormatError& e) {
      PyErr_SetString(g_format_error, e.what());
    } catch (const Error& e) {
      PyErr_SetString(g_error, e.what());
    } catch (const std::filesystem::filesystem_error& e) {
      // As the CLI words it: the path, then what the system said.
      const std::string path = e.path1().empty() ? std::string("a file") : e.path1().string();
      PyErr_SetString(g_error, (path + ": " + e.code().message()).c_str());
    } catch (const std::bad_alloc&) {
      // Not "std::bad_alloc": what ran out, and what to change.
      PyErr_SetString(PyExc_MemoryError, "strata: out of memory: the call needed more memory than this process may "
                                         "allocate; read a smaller box or a coarser level, or use a smaller volume");
    } catch (const std::length_error&) {
      PyErr_SetString(PyExc_MemoryError, "strata: the call needs a buffer larger than this machine can address; read a "
                                         "smaller box or a coarser level, or use a smaller volume");
    } catch (const py::cast_error&) {
      // pybind11's "Unable to cast Python instance to C++ type" names no argument; each binding
      // checks its arguments' types itself, so this is only a safety net.
      PyErr_SetString(PyExc_TypeError, "strata: an argument has a type this function cannot take; help() on the "
                                       "function lists what each argument expects");
    } catch (const nlohmann::json::exception& e) {
      PyErr_SetString(g_error, ("strata: a JSON value was not what was expected (JSON library error " +
                                std::to_string(e.id) + ")")
                                   .c_str());
    }
  });
}

}  // namespace

}  // namespace strata::python

PYBIND11_MODULE(_strata, m) {
  using namespace strata::python;
  m.doc() = "Strata: compressed multiresolution 3D volumes (the compiled part of the strata package)";
  register_errors(m);
  m.def("threads", &strata::thread_count, "The worker threads the library's parallel loops use.");
  m.def(
      "set_threads", [](int n) { strata::set_thread_count(n); }, py::arg("n"),
      "Sets the worker threads (n = 0: all hardware threads), like `strata --threads N`; a negative n or more than "
      "4 x the hardware threads raises strata.ParameterError (a ValueError).");
  register_volume_io(m);
  register_compress(m);
  register_strata_file(m);
  register_label_file(m);
  register_render(m);
}
