#pragma once
/// @file
/// @brief The Python objects strata.open returns: a TA-compressed scalar volume (ScalarFile) or a
/// Mixture Graph label volume (LabelFile). Each holds its decoder through a shared_ptr, so a call
/// that decodes with the GIL released keeps it alive even if another thread closes the file.
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::python {

/// @brief A .strata file of codec ta-bricked or ta-global.
struct ScalarFile {
  std::shared_ptr<const ta::TaVolume> volume;  // null once closed
  std::string codec;
  std::optional<std::int64_t> member;  // the member of a volume set it was opened as

  /// @brief The open decoder; throws py::value_error once the file is closed.
  std::shared_ptr<const ta::TaVolume> get() const;
};

/// @brief A .strata file of codec mixture-graph.
struct LabelFile {
  std::shared_ptr<const mixture::EncodedLabels> labels;  // null once closed
  std::optional<std::int64_t> member;  // the member of a volume set it was opened as

  /// @brief The open decoder; throws py::value_error once the file is closed.
  std::shared_ptr<const mixture::EncodedLabels> get() const;
  /// @brief Per graph node its dominant source id (EncodedLabels::dominant_sources), computed on
  /// first use and kept: every coarse-level read maps node ids through it.
  const std::vector<std::uint32_t>& dominant_sources(const mixture::EncodedLabels& labels);

 private:
  std::once_flag dominant_once_;
  std::vector<std::uint32_t> dominant_;
};

/// @brief The error a closed file raises on use, as Python's own files do.
[[noreturn]] void throw_closed();

/// @brief The metadata of an open .strata container as a Python dict.
py::object metadata_of(const store::ContainerReader& container);

/// @brief What both file classes share: close() and the context-manager protocol, `closed`,
/// numpy-style indexing of level 0 (`f[z0:z1, y0:y1, x0:x1]`) and `f.level(l)` for the others,
/// and the array protocol numpy, dask and xarray look for (`ndim`, `size`, `len()`,
/// `__array__`), with `shape` and `dtype` from each class.
/// Indexing is strata._indexing's, which turns the key into a box, calls read() and applies
/// steps and integer indices to the decoded box. `File` has `get()` and a shared_ptr member
/// `member` that close() resets.
template <class File, class Decoder>
void add_file_protocol(py::class_<File>& cls, std::shared_ptr<const Decoder> File::*member) {
  cls.def("close", [member](File& f) { f.*member = nullptr; }, "Releases the file's mapping; later use raises ValueError.")
      .def_property_readonly("closed", [member](const File& f) { return f.*member == nullptr; })
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [member](File& f, py::args) { f.*member = nullptr; })
      .def("__getitem__",
           [](py::object self, py::object key) {
             return py::module_::import("strata._indexing").attr("getitem")(self, key, 0);
           })
      .def_property_readonly("ndim", [](const File&) { return 3; })
      .def_property_readonly("size",
                             [](py::object self) {
                               std::int64_t n = 1;
                               for (py::handle d : self.attr("shape")) n *= d.cast<std::int64_t>();
                               return n;
                             })
      .def("__len__", [](py::object self) { return self.attr("shape").attr("__getitem__")(0).cast<std::int64_t>(); })
      .def(
          "__array__",
          [](py::object self, py::object dtype, py::object copy) {
            (void)copy;  // the decoded array is always new
            py::object a = self.attr("read")();
            return dtype.is_none() ? a : a.attr("astype")(dtype);
          },
          py::arg("dtype") = py::none(), py::arg("copy") = py::none(),
          "numpy.asarray(f): level 0 decoded whole, as f[...] and f.read() give it.")
      .def(
          "level",
          [](py::object self, int level) {
            self.attr("level_shape")(level);  // checks the level now, not at the first read
            return py::module_::import("strata._indexing").attr("LevelView")(self, level);
          },
          py::arg("level"), "A view of one level: `f.level(2)[...]`, `.shape`, `.read(box=...)`.");
}

}  // namespace strata::python
