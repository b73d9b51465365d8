// strata.read, strata.write, strata.info and strata.generate: volume files (raw + sidecar, NRRD,
// NIfTI, TIFF) and synthetic volumes as numpy arrays, through the io and gen modules.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/formats.hpp"

namespace strata::python {

namespace {

// A placement from strata.write's origin (z, y, x) and unit; axes along the world's.
Geometry geometry_from_python(py::handle origin, const std::string& unit) {
  Geometry g;
  if (!origin.is_none()) {
    if (!py::isinstance<py::sequence>(origin) || py::len(origin) != 3)
      throw py::type_error("origin: expected (z, y, x), got " + std::string(py::repr(origin)));
    const auto o = py::reinterpret_borrow<py::sequence>(origin);
    for (int a = 0; a < 3; ++a) {
      const py::object item = o[std::size_t(a)];
      const bool number = py::isinstance<py::float_>(item) || py::isinstance<py::int_>(item) ||
                          py::hasattr(item, "__float__");
      if (!number || py::isinstance<py::str>(item))
        throw py::type_error("origin: expected three numbers (z, y, x), got " + std::string(py::repr(origin)));
      g.origin[std::size_t(2 - a)] = py::float_(item).cast<double>();
      if (!std::isfinite(g.origin[std::size_t(2 - a)]))
        throw py::value_error("origin: expected finite numbers (z, y, x), got " + std::string(py::repr(origin)));
    }
  }
  if (!unit.empty()) {
    g.unit = canonical_length_unit(unit);
    if (g.unit.empty())
      throw py::value_error("unit: unknown length unit '" + unit + "' (expected m, cm, mm, um, nm or angstrom)");
  }
  return g;
}

py::dict info_dict(const VolumeInfo& info, const std::filesystem::path& path) {
  py::dict d;
  d["path"] = path.string();
  d["format"] = io::detect_format(io::split_container_path(path).first).name;  // scan.h5:/entry/data
  d["shape"] = shape_of(info.dims);
  d["dtype"] = numpy_dtype(info.dtype);
  d["spacing"] = spacing_to_python(info.spacing);
  d["volumes"] = info.volumes;
  for (const auto& [key, value] : geometry_to_python(info.geometry, info.spacing)) d[key] = value;
  return d;
}

}  // namespace

void register_volume_io(py::module_& m) {
  m.def(
      "read",
      [](py::handle path, py::handle shape, py::handle dtype, py::handle spacing, bool big_endian,
         std::optional<std::int64_t> volume, const std::string& dataset, std::optional<std::int64_t> level) {
        const std::filesystem::path p = path_from_python(path, "path");
        io::ReadOptions options = read_options(shape, dtype, spacing, big_endian, volume);
        options.dataset = dataset;
        options.level = level;
        Volume v;
        {
          py::gil_scoped_release release;
          v = io::read_volume(p, options);
        }
        return to_numpy(std::move(v));
      },
      py::arg("path"), py::kw_only(), py::arg("shape") = py::none(), py::arg("dtype") = py::none(),
      py::arg("spacing") = py::none(), py::arg("big_endian") = false, py::arg("volume") = py::none(),
      py::arg("dataset") = "", py::arg("level") = py::none(),
      R"(Reads a volume file (any format of strata.formats()) into a numpy array of shape (z, y, x) in
the file's sample type.

Raw files without a sidecar need shape=(z, y, x) and dtype (and optionally spacing, big_endian).
volume=T picks one 3-D volume of a file of several (4-D NIfTI/NRRD, multi-channel TIFF, t/c axes);
dataset names the array of a container ("/group/data" of HDF5; also "file.h5:/group/data");
level a resolution of a multiscale file (0 the finest). Spacing and placement are returned by
strata.info(path).)");

  m.def(
      "info",
      [](py::handle path, py::handle shape, py::handle dtype, py::handle spacing, bool big_endian,
         std::optional<std::int64_t> volume, const std::string& dataset, std::optional<std::int64_t> level) {
        const std::filesystem::path p = path_from_python(path, "path");
        io::ReadOptions options = read_options(shape, dtype, spacing, big_endian, volume);
        options.dataset = dataset;
        options.level = level;
        if (!options.volume) options.volume = 0;  // the header of a file of several volumes, not a refusal
        std::unique_ptr<io::VolumeSource> source;
        {
          py::gil_scoped_release release;
          source = io::open_volume(p, options);
        }
        py::dict d = info_dict(source->info(), p);
        py::gil_scoped_release release;
        source.reset();
        return d;
      },
      py::arg("path"), py::kw_only(), py::arg("shape") = py::none(), py::arg("dtype") = py::none(),
      py::arg("spacing") = py::none(), py::arg("big_endian") = false, py::arg("volume") = py::none(),
      py::arg("dataset") = "", py::arg("level") = py::none(),
      "The header of a volume file without its samples: a dict with path, format, shape (z, y, x), dtype, "
      "spacing (z, y, x), volumes (3-D volumes in the file), and where the volume lies: origin (z, y, x), "
      "affine (4x4, array index (z, y, x) to world (z, y, x)), unit and world_space (RAS, LPS or unspecified).");

  m.def(
      "write",
      [](py::handle path, py::handle array, py::handle spacing, py::handle origin, const std::string& unit,
         bool compress) {
        const std::filesystem::path p = path_from_python(path, "path");
        const py::array a = volume_array(array, "array");
        io::WriteOptions options;
        options.compress = compress;
        const Spacing s = spacing_from_python(spacing, "spacing");
        // The array is read with the GIL released: a second reference keeps it alive meanwhile.
        VolumeInfo info = array_info(a, s);
        info.geometry = geometry_from_python(origin, unit);
        const std::byte* data = static_cast<const std::byte*>(a.data());
        py::gil_scoped_release release;
        auto writer = io::create_volume_writer(p, info, options);
        // Slabs of about 64 MiB: the writer streams, so a large array is never copied whole.
        const std::int64_t slice_bytes = std::int64_t(info.bytes_per_slice());
        const std::int64_t slab = std::max<std::int64_t>(1, (std::int64_t(64) << 20) / slice_bytes);
        for (std::int64_t z = 0; z < info.dims.z; z += slab) {
          const std::int64_t z1 = std::min(info.dims.z, z + slab);
          Volume v({info.dims.x, info.dims.y, z1 - z}, info.dtype, s);
          std::memcpy(v.bytes(), data + z * slice_bytes, v.byte_size());
          writer->write_slab(v);
        }
        writer->finish();
      },
      py::arg("path"), py::arg("array"), py::kw_only(), py::arg("spacing") = py::none(), py::arg("origin") = py::none(),
      py::arg("unit") = "", py::arg("compress") = true,
      R"(Writes a (z, y, x) numpy array as a volume file; the format comes from the extension (any
writable format of strata.formats()). spacing=(sz, sy, sx) defaults to 1, origin=(z, y, x) the world
position of voxel 0's centre to 0; unit names their length unit ("mm", "um", "nm", "angstrom").
compress=False stores uncompressed where the format compresses. The file appears only once complete.)");

  m.def(
      "generate",
      [](const std::string& kind, py::handle shape, std::uint64_t seed, std::int64_t count, py::handle dtype) {
        gen::Params p;
        p.kind = gen::parse_kind(kind);
        const io::ReadOptions dims = read_options(shape, py::none(), py::none(), false, std::nullopt);
        if (!dims.raw_dims) throw py::value_error("shape: expected (z, y, x)");
        p.dims = *dims.raw_dims;
        p.seed = seed;
        p.count = count;
        if (!dtype.is_none()) p.output_dtype = dtype_from_python(dtype, "dtype");
        Volume v;
        {
          py::gil_scoped_release release;
          v = gen::generate(p);
        }
        return to_numpy(std::move(v));
      },
      py::arg("kind"), py::arg("shape"), py::kw_only(), py::arg("seed") = 1, py::arg("count") = 0,
      py::arg("dtype") = py::none(),
      R"(A synthetic volume, as `strata generate` writes it: kind is prisms, marschner-lobb or sphere
(scalar) or voronoi, fibres or superpixels (labels, uint32); shape is (z, y, x); count the number of
objects (0 = the kind's default); dtype converts the samples.)");
}

}  // namespace strata::python
