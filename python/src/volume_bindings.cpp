// strata.read, strata.write, strata.info and strata.generate: volume files (raw + sidecar, NRRD,
// NIfTI, TIFF) and synthetic volumes as numpy arrays, through the io and gen modules.
#include <algorithm>
#include <cstring>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/formats.hpp"

namespace strata::python {

namespace {

py::dict info_dict(const VolumeInfo& info, const std::filesystem::path& path) {
  py::dict d;
  d["path"] = path.string();
  d["format"] = io::detect_format(io::split_container_path(path).first).name;  // scan.h5:/entry/data
  d["shape"] = shape_of(info.dims);
  d["dtype"] = numpy_dtype(info.dtype);
  d["spacing"] = spacing_to_python(info.spacing);
  d["volumes"] = info.volumes;
  return d;
}

}  // namespace

void register_volume_io(py::module_& m) {
  m.def(
      "read",
      [](py::handle path, py::handle shape, py::handle dtype, py::handle spacing, bool big_endian,
         std::optional<std::int64_t> volume) {
        const std::filesystem::path p = path_from_python(path, "path");
        const io::ReadOptions options = read_options(shape, dtype, spacing, big_endian, volume);
        Volume v;
        {
          py::gil_scoped_release release;
          v = io::read_volume(p, options);
        }
        return to_numpy(std::move(v));
      },
      py::arg("path"), py::kw_only(), py::arg("shape") = py::none(), py::arg("dtype") = py::none(),
      py::arg("spacing") = py::none(), py::arg("big_endian") = false, py::arg("volume") = py::none(),
      R"(Reads a volume file (raw with a JSON sidecar, NRRD, NIfTI-1/2, TIFF) into a numpy array of
shape (z, y, x) in the file's sample type.

Raw files without a sidecar need shape=(z, y, x) and dtype (and optionally spacing, big_endian).
volume=T picks one 3-D volume of a 4-D NIfTI/NRRD or multi-channel TIFF. The spacing is
returned by strata.info(path).)");

  m.def(
      "info",
      [](py::handle path, py::handle shape, py::handle dtype, py::handle spacing, bool big_endian,
         std::optional<std::int64_t> volume) {
        const std::filesystem::path p = path_from_python(path, "path");
        io::ReadOptions options = read_options(shape, dtype, spacing, big_endian, volume);
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
      "The header of a volume file without its samples: a dict with path, format, shape (z, y, x), dtype, "
      "spacing (z, y, x) and volumes (3-D volumes in the file).");

  m.def(
      "write",
      [](py::handle path, py::handle array, py::handle spacing, bool compress) {
        const std::filesystem::path p = path_from_python(path, "path");
        const py::array a = volume_array(array, "array");
        io::WriteOptions options;
        options.compress = compress;
        const Spacing s = spacing_from_python(spacing, "spacing");
        // The array is read with the GIL released: a second reference keeps it alive meanwhile.
        const VolumeInfo info = array_info(a, s);
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
      py::arg("path"), py::arg("array"), py::kw_only(), py::arg("spacing") = py::none(), py::arg("compress") = true,
      R"(Writes a (z, y, x) numpy array as a volume file; the format comes from the extension (.raw/.bin
with a .raw.json sidecar, .nrrd, .nhdr, .nii, .nii.gz, .tif/.tiff). spacing=(sz, sy, sx) defaults to
1. compress=False stores NRRD uncompressed. The file appears only once complete.)");

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
