#pragma once
/// @file
/// @brief What the binding files of the `strata` Python module share: the numpy <-> Volume
/// conversions, boxes and spacings in array order, the progress adapter, and each file's
/// registration function (module.cpp calls them).
///
/// Axis order: a volume is x fastest, so its samples are exactly a C-ordered numpy array of
/// shape (z, y, x). Everything the Python API takes or returns per axis (shape, spacing, boxes as
/// slices or pairs) follows that array order; only the CLI's box text "x0,y0,z0:x1,y1,z1" keeps
/// the CLI's x-first order.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>  // std::optional, std::vector and std::array arguments

#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::python {

namespace py = pybind11;

/// @brief Registers the functions and classes of one concern on the module.
void register_volume_io(py::module_& m);        // volume_bindings.cpp: read, write, info, generate
void register_compress(py::module_& m);         // compress_bindings.cpp: compress, labels.encode
void register_strata_file(py::module_& m);      // strata_file_bindings.cpp: open, ScalarFile
void register_label_file(py::module_& m);       // labels_bindings.cpp: LabelFile
void register_render(py::module_& m);           // render_bindings.cpp: Renderer, render

/// @brief The numpy dtype of a sample type (native byte order).
py::dtype numpy_dtype(DType t);
/// @brief The sample type a numpy dtype or a name ("u16", "uint16", "float32", numpy.uint16)
/// stands for. Throws py::type_error naming `what` for types volumes cannot hold.
DType dtype_from_python(py::handle obj, const char* what);

/// @brief `obj` as a C-contiguous numpy array of native byte order and a volume sample type,
/// without a copy when it already is one (a strided view or a byte-swapped array is copied).
/// Throws py::type_error for other dtypes and non-arrays, py::value_error unless it has three
/// dimensions, each at least 1, naming `what`.
py::array volume_array(py::handle obj, const char* what);
/// @brief The VolumeInfo of an array volume_array accepted, with `spacing`.
VolumeInfo array_info(const py::array& array, const Spacing& spacing);
/// @brief `volume` as a (z, y, x) numpy array that owns its samples (moved, not copied).
py::array to_numpy(Volume volume);

/// @brief Spacing from a Python (z, y, x) triple of positive numbers; None gives `fallback`.
/// Throws py::value_error naming `what` otherwise.
Spacing spacing_from_python(py::handle obj, const char* what, Spacing fallback = {});
/// @brief The (z, y, x) tuple of a spacing.
py::tuple spacing_to_python(const Spacing& s);
/// @brief The (z, y, x) tuple of dims.
py::tuple shape_of(const Extent& dims);
/// @brief The 4x4 index-to-world affine of `geometry` and `spacing` in array order: it maps
/// (z, y, x, 1) array indices to world coordinates listed (z, y, x) as well, the convention of
/// napari's `affine=` and of `spacing` here. A nibabel-style (i, j, k) -> (x, y, z) affine is it
/// with rows and columns 0..2 reversed.
py::array affine_to_python(const Geometry& geometry, const Spacing& spacing);
/// @brief A dict of a volume's placement: origin (z, y, x), affine (affine_to_python), unit
/// ("" unknown) and world_space ("RAS", "LPS" or "unspecified").
py::dict geometry_to_python(const Geometry& geometry, const Spacing& spacing);

/// @brief A box of a volume of `dims` from Python: None (the whole volume), the CLI's text
/// "x0,y0,z0:x1,y1,z1", or three items in (z, y, x) order, each a slice of step 1 (numpy rules:
/// negative and open bounds, stops clamped) or a (lo, hi) pair of integers. Throws
/// py::value_error unless the result is non-empty and inside the volume, py::type_error for
/// other objects.
Box box_from_python(py::handle obj, const Extent& dims);

/// @brief Python objects from JSON (through the json module, so numbers and nesting are exact).
py::object json_to_python(const nlohmann::json& j);
/// @brief JSON from a Python object (dict, list, numbers, strings) through the json module.
/// Throws py::value_error naming `what` for NaN, infinities and self-containing objects,
/// py::type_error for objects JSON has no form for.
nlohmann::json json_from_python(py::handle obj, const char* what);

/// @brief An integer argument (int or an object with __index__, such as numpy.int64) as int64.
/// Throws py::type_error naming `what` for other objects, py::value_error outside the int64 range.
std::int64_t index_from_python(py::handle obj, const char* what);

/// @brief Raw-file reading options from keyword arguments: shape (z, y, x), dtype, spacing
/// (z, y, x), big_endian, volume (None or an index). Raw files without a JSON sidecar need
/// shape and dtype.
io::ReadOptions read_options(py::handle shape, py::handle dtype, py::handle spacing, bool big_endian,
                             std::optional<std::int64_t> volume);

/// @brief A volume the compressors read: a file (any format io reads; shape, dtype, spacing,
/// big_endian and volume as read_options takes them) or a numpy array (with `spacing` in
/// (z, y, x) order; the raw-file arguments must be unset) served through io::VolumeSource without
/// copying it. Built with the GIL held; read from any thread while the GIL is released (the array
/// is only read through its data pointer, and the reference that keeps it alive is dropped with
/// the GIL held).
std::unique_ptr<io::VolumeSource> open_source(py::handle array_or_path, py::handle shape, py::handle dtype,
                                              py::handle spacing, bool big_endian, std::optional<std::int64_t> volume);

/// @brief A path argument: str or os.PathLike. Throws py::type_error otherwise.
std::filesystem::path path_from_python(py::handle obj, const char* what);

/// @brief A ProgressSink that forwards to a Python callable `callback(task, done, total)`.
///
/// The library reports from its worker threads, and the GIL is released while it works, so the
/// callback is only called from the thread that created the sink (it reports there too, in the
/// parallel loops), at most every 0.1 s plus at the start and end of each task; units counted
/// on other threads are included in the next call. An exception the callback raises is kept,
/// the callback is not called again, and rethrow() raises it once the operation is over (the
/// library's loops cannot be left from inside a report).
class PythonProgress final : public ProgressSink {
 public:
  /// @brief None or False: silent; True: the text bar strata._progress.ProgressBar; a callable:
  /// called as described. Throws py::type_error for anything else.
  explicit PythonProgress(py::handle progress);
  ~PythonProgress() override;

  void begin(std::string_view task, std::uint64_t total, std::string_view unit) override;
  void advance(std::uint64_t units) override;
  void end() override;

  /// @brief Raises what the callback raised, if anything. Call with the GIL held.
  void rethrow();

 private:
  void report(bool force);

  py::object callback_;
  std::thread::id owner_ = std::this_thread::get_id();
  std::mutex mutex_;  // task_ and total_
  std::string task_;
  std::uint64_t total_ = 0;
  std::atomic<std::uint64_t> done_{0};
  std::chrono::steady_clock::time_point last_{};
  std::exception_ptr error_;
};

}  // namespace strata::python
