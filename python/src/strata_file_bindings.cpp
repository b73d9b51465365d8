// strata.open and ScalarFile: a compressed .strata file, decoded box by box (ta::TaVolume).
#include <string>

#include <fmt/format.h>

#include "bindings.hpp"
#include "files.hpp"
#include "strata/core/error.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::python {

void throw_closed() { throw py::value_error("I/O operation on a closed strata file"); }

std::shared_ptr<const ta::TaVolume> ScalarFile::get() const {
  if (!volume) throw_closed();
  return volume;
}

py::object metadata_of(const store::ContainerReader& container) { return json_to_python(container.metadata()); }

namespace {

// The reconstruction rank K of a read: None or 0 is the stored rank; otherwise 1..stored, the
// rule of `strata decompress --rank` (ta::reconstruction_rank; strata.ParameterError otherwise).
int read_rank(const ta::TaVolume& v, std::optional<int> rank) { return v.reconstruction_rank(rank.value_or(0)); }

// The sample type a read returns, as `strata decompress` writes it: level 0 in the source's type
// (rounded and clamped) unless as_float; coarser levels hold averages, so float32.
DType read_dtype(const ta::TaVolume& v, int level, bool as_float) {
  return as_float || level > 0 ? DType::f32 : v.source_info().dtype;
}

py::object open_file(py::handle path, std::optional<std::int64_t> volume) {
  const std::filesystem::path p = path_from_python(path, "path");
  if (volume && *volume < 0) throw py::value_error("volume: must be a non-negative index, got " + std::to_string(*volume));
  std::unique_ptr<store::ContainerReader> container;
  {
    py::gil_scoped_release release;
    container = store::open_volume(p, volume);
  }
  const auto codec = container->metadata().find("codec");
  if (codec != container->metadata().end() && codec->is_string() && *codec == mixture::kMixtureCodecName) {
    auto file = std::make_unique<LabelFile>();
    file->member = volume;
    {
      py::gil_scoped_release release;
      file->labels = std::make_shared<const mixture::EncodedLabels>(std::move(container));
    }
    return py::cast(std::move(file));
  }
  // Anything else is checked (and, if not a TA file, refused with the file and field) by TaVolume.
  auto file = std::make_unique<ScalarFile>();
  file->member = volume;
  {
    py::gil_scoped_release release;
    file->volume = std::make_shared<const ta::TaVolume>(std::move(container));
  }
  file->codec = file->volume->codec_name();
  return py::cast(std::move(file));
}

}  // namespace

void register_strata_file(py::module_& m) {
  m.def("open", &open_file, py::arg("path"), py::kw_only(), py::arg("volume") = py::none(),
        R"(Opens a .strata file: a ScalarFile (codec ta-bricked or ta-global) or a LabelFile (codec
mixture-graph). volume=T opens member T of a volume set. Nothing is decoded until it is read.)");

  py::class_<ScalarFile> cls(m, "ScalarFile", R"(A compressed scalar volume (strata.open on a TA file).

f[z0:z1, y0:y1, x0:x1] decodes level 0 at the stored rank in the source's sample type;
f.level(l)[...] a coarser level (float32); f.read(box=..., level=..., rank=...) any box, level and
reconstruction rank. Only the bricks a box touches are decoded.)");
  cls.def_property_readonly("path", [](const ScalarFile& f) { return f.get()->container().path().string(); })
      .def_property_readonly(
          "transfer",
          [](const ScalarFile& f) {
            const io::TransferStats s = f.get()->container().source().transfer_stats();
            py::dict d;
            d["bytes_fetched"] = s.bytes_fetched;
            d["requests"] = s.requests;
            d["retries"] = s.retries;
            d["cache_hits"] = s.cache_hits;
            return d;
          },
          "For a file opened from an http(s) URL, what reading it cost so far: bytes_fetched, requests, retries, "
          "cache_hits (all 0 for a local file).")
      .def_readonly("codec", &ScalarFile::codec)
      .def_readonly("volume", &ScalarFile::member, "The member of a volume set opened (None: the file itself).")
      .def_property_readonly("shape", [](const ScalarFile& f) { return shape_of(f.get()->source_info().dims); })
      .def_property_readonly("dtype", [](const ScalarFile& f) { return numpy_dtype(f.get()->source_info().dtype); })
      .def_property_readonly("spacing", [](const ScalarFile& f) { return spacing_to_python(f.get()->source_info().spacing); })
      .def_property_readonly(
          "affine", [](const ScalarFile& f) { return affine_to_python(f.get()->source_info().geometry, f.get()->source_info().spacing); },
          "4x4 index-to-world transform of level 0 in array order: (z, y, x, 1) to world (z, y, x).")
      .def_property_readonly(
          "origin",
          [](const ScalarFile& f) { return geometry_to_python(f.get()->source_info().geometry, {})["origin"]; },
          "World position (z, y, x) of the centre of voxel 0.")
      .def_property_readonly("unit", [](const ScalarFile& f) { return f.get()->source_info().geometry.unit; })
      .def_property_readonly("world_space",
                             [](const ScalarFile& f) { return std::string(world_space_name(f.get()->source_info().geometry.space)); })
      .def_property_readonly("levels", [](const ScalarFile& f) { return f.get()->geometry().level_count(); })
      .def_property_readonly("rank", [](const ScalarFile& f) { return f.get()->rank(); }, "The stored rank.")
      .def_property_readonly("brick", [](const ScalarFile& f) { return f.get()->geometry().layout().brick; })
      .def_property_readonly("quant", [](const ScalarFile& f) { return f.get()->quant_name(); })
      .def_property_readonly("value_range",
                             [](const ScalarFile& f) { return py::make_tuple(f.get()->value_min(), f.get()->value_max()); })
      .def_property_readonly("metadata", [](const ScalarFile& f) { return metadata_of(f.get()->container()); })
      .def(
          "level_shape",
          [](const ScalarFile& f, int level) {
            const auto v = f.get();
            v->check_level(level);
            return shape_of(v->geometry().level(level).dims);
          },
          py::arg("level"), "The (z, y, x) shape of a level (level 0 is the volume, each next one half as fine).")
      .def(
          "read_dtype",
          [](const ScalarFile& f, int level, bool as_float) { return numpy_dtype(read_dtype(*f.get(), level, as_float)); },
          py::arg("level") = 0, py::arg("as_float") = false, "The sample type read() returns for these arguments.")
      .def(
          "read",
          [](const ScalarFile& f, py::handle box, int level, std::optional<int> rank, bool as_float) {
            const auto v = f.get();
            v->check_level(level);
            const Box b = box_from_python(box, v->geometry().level(level).dims);
            const int k = read_rank(*v, rank);
            const DType type = read_dtype(*v, level, as_float);
            Volume decoded;
            {
              py::gil_scoped_release release;
              decoded = v->decode_box(level, b, k);
              if (decoded.dtype() != type) decoded = decoded.converted(type);
            }
            return to_numpy(std::move(decoded));
          },
          py::arg("box") = py::none(), py::kw_only(), py::arg("level") = 0, py::arg("rank") = py::none(),
          py::arg("as_float") = false,
          R"(Decodes a box of a level at reconstruction rank `rank` (None: the stored rank) into a
(z, y, x) array, decoding only the bricks it touches. box: None (the whole level), three slices or
(lo, hi) pairs in (z, y, x) order, or the CLI's text "x0,y0,z0:x1,y1,z1". Level 0 comes back in
the source's sample type (rounded and clamped, like `strata decompress`) unless as_float.)")
      .def("__repr__", [](const ScalarFile& f) {
        if (!f.volume) return std::string("<strata.ScalarFile (closed)>");
        const Extent d = f.volume->source_info().dims;
        return fmt::format("<strata.ScalarFile '{}' {} shape=({}, {}, {}) {} levels={} rank={}>",
                           f.volume->container().name(), f.codec, d.z, d.y, d.x,
                           dtype_name(f.volume->source_info().dtype), f.volume->geometry().level_count(),
                           f.volume->rank());
      });
  add_file_protocol(cls, &ScalarFile::volume);
}

}  // namespace strata::python
