// numpy <-> Volume, spacings, boxes and paths: the conversions every binding file uses.
#include <cmath>
#include <cstring>
#include <string>

#include <fmt/format.h>

#include "bindings.hpp"
#include "strata/core/error.hpp"
#include "strata/io/files.hpp"

namespace strata::python {

namespace {

constexpr const char* kSupportedTypes =
    "uint8, int8, uint16, int16, uint32, int32, uint64, int64, float32 or float64";

template <class T>
bool holds(const py::array& a) {
  return py::isinstance<py::array_t<T, 0>>(a);
}

// The sample type of an array of native byte order, or nullopt.
std::optional<DType> sample_type(const py::array& a) {
  std::optional<DType> found;
  for (const DType t : kAllDTypes)
    visit_dtype(t, [&](auto v) {
      if (!found && holds<decltype(v)>(a)) found = t;
    });
  return found;
}

// "(2048, 2048, 2048) uint16"
std::string shape_and_type(const py::array& a) {
  std::string shape;
  for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
  return "(" + shape + ") " + std::string(py::str(a.dtype()));
}

// A numpy call `copy` that returns a copy of `a`; numpy's MemoryError (the copy could not be
// allocated) is raised again as a MemoryError that says which argument and how much memory.
template <class Copy>
py::array copied(const py::array& a, const char* what, const char* purpose, Copy&& copy) {
  try {
    return py::reinterpret_borrow<py::array>(copy());
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_MemoryError)) throw;
    const double gib = double(a.size()) * double(a.itemsize()) / double(1 << 30);
    const std::string message = fmt::format(
        "{}: the {} array needs a copy {} ({:.1f} GiB), which could not be allocated; pass a C-contiguous array of "
        "native byte order, which is used without a copy",
        what, shape_and_type(a), purpose, gib);
    PyErr_SetString(PyExc_MemoryError, message.c_str());
    throw py::error_already_set();
  }
}

}  // namespace

std::int64_t index_from_python(py::handle obj, const char* what) {
  if (!py::isinstance<py::int_>(obj) && !py::hasattr(obj, "__index__"))
    throw py::type_error(fmt::format("{}: expected integers, got {}", what, std::string(py::str(obj.get_type()))));
  const auto index = py::reinterpret_steal<py::object>(PyNumber_Index(obj.ptr()));
  if (!index) throw py::error_already_set();  // what its __index__ raised
  int overflow = 0;
  const long long value = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
  if (overflow != 0)
    throw py::value_error(fmt::format("{}: expected integers in [-2^63, 2^63-1], got {}", what, std::string(py::repr(obj))));
  if (value == -1 && PyErr_Occurred()) throw py::error_already_set();
  return value;
}

py::dtype numpy_dtype(DType t) {
  return visit_dtype(t, [](auto v) { return py::dtype::of<decltype(v)>(); });
}

DType dtype_from_python(py::handle obj, const char* what) {
  if (py::isinstance<py::str>(obj)) {
    try {
      return parse_dtype(py::cast<std::string>(obj), what);
    } catch (const Error&) {
      // Not one of our names: numpy may know it ("<u2", "float32").
    }
  }
  py::dtype d;
  try {
    d = py::dtype::from_args(py::reinterpret_borrow<py::object>(obj));
  } catch (const py::error_already_set&) {
    throw py::type_error(fmt::format("{}: not a sample type: {}", what, std::string(py::repr(obj))));
  }
  for (const DType t : kAllDTypes)
    if (d.attr("__eq__")(numpy_dtype(t)).cast<bool>()) return t;
  throw py::type_error(
      fmt::format("{}: {} samples are not supported; volumes hold {}", what, std::string(py::str(d)), kSupportedTypes));
}

py::array volume_array(py::handle obj, const char* what) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(fmt::format("{}: expected a numpy array, got {}", what, std::string(py::str(obj.get_type()))));
  auto a = py::reinterpret_borrow<py::array>(obj);
  if (a.ndim() != 3)
    throw py::value_error(fmt::format("{}: expected a 3-D array of shape (z, y, x), got {} dimension{}", what, a.ndim(),
                                      a.ndim() == 1 ? "" : "s"));
  for (int i = 0; i < 3; ++i)
    if (a.shape(i) < 1)
      throw py::value_error(fmt::format("{}: every dimension needs at least one voxel, got shape ({}, {}, {})", what,
                                        a.shape(0), a.shape(1), a.shape(2)));
  if (!sample_type(a)) {
    // The same type in the other byte order is converted; anything else is refused.
    const py::dtype native = a.dtype().attr("newbyteorder")("=");
    dtype_from_python(native, what);  // throws type_error for unsupported types
    a = copied(a, what, "in native byte order", [&] { return a.attr("astype")(native); });
  }
  // A strided view (a[::2], a.T, zero or negative strides) becomes a contiguous copy, which may
  // not fit in memory; a contiguous array is used as is.
  if (a.flags() & py::array::c_style) return a;
  return copied(a, what, "in C order", [&] { return py::module_::import("numpy").attr("ascontiguousarray")(a); });
}

VolumeInfo array_info(const py::array& array, const Spacing& spacing) {
  VolumeInfo info;
  info.dims = {array.shape(2), array.shape(1), array.shape(0)};
  info.dtype = *sample_type(array);
  info.spacing = spacing;
  return info;
}

py::array to_numpy(Volume volume) {
  const Extent d = volume.dims();
  const py::dtype dtype = numpy_dtype(volume.dtype());
  auto* owner = new Volume(std::move(volume));
  py::capsule base(owner, [](void* p) { delete static_cast<Volume*>(p); });
  const auto size = py::ssize_t(dtype.itemsize());
  return py::array(dtype, {d.z, d.y, d.x}, {d.y * d.x * size, d.x * size, size}, owner->bytes(), base);
}

Spacing spacing_from_python(py::handle obj, const char* what, Spacing fallback) {
  if (obj.is_none()) return fallback;
  std::vector<double> v;
  try {
    v = py::cast<std::vector<double>>(obj);
  } catch (const py::cast_error&) {
    throw py::type_error(fmt::format("{}: expected a (z, y, x) sequence of numbers, got {}", what,
                                     std::string(py::repr(obj))));
  }
  if (v.size() != 3 || !(v[0] > 0 && v[1] > 0 && v[2] > 0) || !std::isfinite(v[0] + v[1] + v[2]))
    throw py::value_error(fmt::format("{}: expected three finite positive numbers (z, y, x), got {}", what,
                                      std::string(py::repr(obj))));
  return {v[2], v[1], v[0]};
}

py::tuple spacing_to_python(const Spacing& s) { return py::make_tuple(s.z, s.y, s.x); }

py::tuple shape_of(const Extent& dims) { return py::make_tuple(dims.z, dims.y, dims.x); }

py::array affine_to_python(const Geometry& geometry, const Spacing& spacing) {
  const Matrix4 xyz = index_to_world(geometry, spacing);
  py::array_t<double> a({4, 4});
  auto m = a.mutable_unchecked<2>();
  for (py::ssize_t r = 0; r < 4; ++r)
    for (py::ssize_t c = 0; c < 4; ++c) {
      // Axes 0..2 reversed ((x, y, z) -> (z, y, x)); the homogeneous row and column stay.
      const std::size_t rr = r < 3 ? std::size_t(2 - r) : 3, cc = c < 3 ? std::size_t(2 - c) : 3;
      m(r, c) = xyz[rr][cc];
    }
  return a;
}

py::dict geometry_to_python(const Geometry& geometry, const Spacing& spacing) {
  py::dict d;
  d["origin"] = py::make_tuple(geometry.origin[2], geometry.origin[1], geometry.origin[0]);
  d["affine"] = affine_to_python(geometry, spacing);
  d["unit"] = geometry.unit;
  d["world_space"] = std::string(world_space_name(geometry.space));
  return d;
}

Box box_from_python(py::handle obj, const Extent& dims) {
  const Box whole = Box::whole(dims);
  Box box = whole;
  if (obj.is_none()) return box;
  if (py::isinstance<py::str>(obj)) {
    try {
      box = parse_box(py::cast<std::string>(obj));
    } catch (const Error& e) {
      throw py::value_error(std::string("box: ") + e.what());
    }
  } else {
    if (!py::isinstance<py::sequence>(obj) || py::len(obj) != 3)
      throw py::type_error("box: expected three slices or (lo, hi) pairs in (z, y, x) order, or \"x0,y0,z0:x1,y1,z1\", "
                           "got " + std::string(py::repr(obj)));
    const auto items = py::reinterpret_borrow<py::sequence>(obj);
    const std::int64_t extent[3] = {dims.z, dims.y, dims.x};
    std::int64_t lo[3], hi[3];
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const py::object item = items[axis];
      if (py::isinstance<py::slice>(item)) {
        py::ssize_t start = 0, stop = 0, step = 0, length = 0;
        if (!py::reinterpret_borrow<py::slice>(item).compute(py::ssize_t(extent[axis]), &start, &stop, &step, &length))
          throw py::error_already_set();
        if (step != 1) throw py::value_error("box: slices of a box have step 1, got " + std::string(py::repr(item)));
        lo[axis] = start;
        hi[axis] = std::max(start, stop);
      } else {
        if (!py::isinstance<py::sequence>(item) || py::isinstance<py::str>(item) || py::len(item) != 2)
          throw py::type_error("box: each axis is a slice or a (lo, hi) pair, got " + std::string(py::repr(item)));
        lo[axis] = index_from_python(item[py::int_(0)], "box");
        hi[axis] = index_from_python(item[py::int_(1)], "box");
      }
    }
    box = {{lo[2], lo[1], lo[0]}, {hi[2], hi[1], hi[0]}};
  }
  if (box.empty() || !whole.contains(box))
    throw py::value_error(fmt::format("box: expected a non-empty box inside the volume of shape (z, y, x) = ({}, {}, {}), "
                                      "got x0,y0,z0:x1,y1,z1 = {}",
                                      dims.z, dims.y, dims.x, box.to_string()));
  return box;
}

py::object json_to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

nlohmann::json json_from_python(py::handle obj, const char* what) {
  std::string text;
  try {
    // allow_nan=False: NaN and infinities have no JSON form (json.dumps would write NaN).
    text = py::cast<std::string>(py::module_::import("json").attr("dumps")(obj, py::arg("allow_nan") = false));
  } catch (py::error_already_set& e) {
    if (e.matches(PyExc_ValueError))
      throw py::value_error(fmt::format("{}: expected finite numbers (NaN and infinities have no JSON form) and no "
                                        "list or dict that holds itself",
                                        what));
    if (e.matches(PyExc_TypeError))
      throw py::type_error(fmt::format("{}: expected JSON data (dicts, lists, str, numbers, bools, None): {}", what,
                                       std::string(py::str(e.value()))));
    throw;
  }
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw py::value_error(fmt::format("{}: not readable as JSON: {}", what, io::json_error_reason(e)));
  }
}

std::filesystem::path path_from_python(py::handle obj, const char* what) {
  if (py::isinstance<py::str>(obj)) return py::cast<std::string>(obj);
  if (py::hasattr(obj, "__fspath__")) {
    const py::object p = obj.attr("__fspath__")();
    if (py::isinstance<py::str>(p)) return py::cast<std::string>(p);
  }
  throw py::type_error(fmt::format("{}: expected a path (str or os.PathLike), got {}", what,
                                   std::string(py::str(obj.get_type()))));
}

io::ReadOptions read_options(py::handle shape, py::handle dtype, py::handle spacing, bool big_endian,
                             std::optional<std::int64_t> volume) {
  io::ReadOptions o;
  if (!shape.is_none()) {
    if (!py::isinstance<py::sequence>(shape) || py::len(shape) != 3)
      throw py::type_error("shape: expected (z, y, x), got " + std::string(py::repr(shape)));
    const auto s = py::reinterpret_borrow<py::sequence>(shape);
    o.raw_dims = Extent{index_from_python(s[2], "shape"), index_from_python(s[1], "shape"), index_from_python(s[0], "shape")};
  }
  if (!dtype.is_none()) o.raw_dtype = dtype_from_python(dtype, "dtype");
  if (!spacing.is_none()) o.raw_spacing = spacing_from_python(spacing, "spacing");
  o.raw_big_endian = big_endian;
  if (volume && *volume < 0) throw py::value_error("volume: must be a non-negative index, got " + std::to_string(*volume));
  o.volume = volume;
  return o;
}

namespace {

// A numpy array served to the compressors as a volume on disk would be: boxes are copied out of
// the array's buffer on request, so the array itself is never copied whole.
class ArraySource final : public io::VolumeSource {
 public:
  ArraySource(py::array array, const Spacing& spacing)
      : array_(std::move(array)), info_(array_info(array_, spacing)), path_("<numpy array>"),
        data_(static_cast<const std::byte*>(array_.data())) {}
  ~ArraySource() override {
    py::gil_scoped_acquire gil;  // the last reference may go with the GIL released elsewhere
    array_ = py::array();
  }

  const VolumeInfo& info() const override { return info_; }
  const std::filesystem::path& path() const override { return path_; }

  Volume read_box(const Box& box) override {
    if (box.empty() || !Box::whole(info_.dims).contains(box))
      throw Error(fmt::format("{}: box {} is not inside the volume {}", path_.string(), box.to_string(),
                              info_.dims.to_string()));
    Volume out(box.size(), info_.dtype, info_.spacing);
    const std::size_t sample = dtype_size(info_.dtype);
    const std::size_t row = std::size_t(box.size().x) * sample;
    std::byte* dst = out.bytes();
    for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
      for (std::int64_t y = box.lo.y; y < box.hi.y; ++y, dst += row)
        std::memcpy(dst, data_ + (std::size_t((z * info_.dims.y + y) * info_.dims.x + box.lo.x)) * sample, row);
    return out;
  }

 private:
  py::array array_;
  VolumeInfo info_;
  std::filesystem::path path_;
  const std::byte* data_;
};

}  // namespace

std::unique_ptr<io::VolumeSource> open_source(py::handle array_or_path, py::handle shape, py::handle dtype,
                                              py::handle spacing, bool big_endian, std::optional<std::int64_t> volume) {
  if (py::isinstance<py::array>(array_or_path)) {
    if (!shape.is_none() || !dtype.is_none() || big_endian || volume)
      throw py::value_error("shape, dtype, big_endian and volume describe raw files; an array has its own");
    return std::make_unique<ArraySource>(volume_array(array_or_path, "array"), spacing_from_python(spacing, "spacing"));
  }
  const std::filesystem::path path = path_from_python(array_or_path, "source");
  const io::ReadOptions options = read_options(shape, dtype, spacing, big_endian, volume);
  py::gil_scoped_release release;  // gzip inputs are decoded to a temporary file here
  return io::open_volume(path, options);
}

}  // namespace strata::python
