// LabelFile: a Mixture Graph label volume (mixture::EncodedLabels) read box by box, its box
// histogram queries (mixture::BoxQuery), label fractions and palettes (mixture::propagate_palette).
#include <array>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "bindings.hpp"
#include "files.hpp"
#include "strata/core/error.hpp"
#include "strata/mixture/box_query.hpp"
#include "strata/mixture/palette.hpp"

namespace strata::python {

std::shared_ptr<const mixture::EncodedLabels> LabelFile::get() const {
  if (!labels) throw_closed();
  return labels;
}

const std::vector<std::uint32_t>& LabelFile::dominant_sources(const mixture::EncodedLabels& l) {
  std::call_once(dominant_once_, [&] { dominant_ = l.dominant_sources(); });
  return dominant_;
}

namespace {

void check_level(const mixture::EncodedLabels& l, int level) {
  if (level < 0 || level >= l.level_count())
    throw py::value_error(fmt::format("level: must be 0..{} for {}, got {}", l.level_count() - 1, l.name(), level));
}

Spacing level_spacing(const mixture::EncodedLabels& l, int level) {
  const double s = std::ldexp(1.0, level);
  return {l.spacing().x * s, l.spacing().y * s, l.spacing().z * s};
}

// The node id of every voxel of `box` at `level`.
std::vector<std::uint32_t> node_ids(const mixture::EncodedLabels& l, int level, const Box& box) {
  std::vector<std::uint32_t> ids(std::size_t(box.voxel_count()));
  l.decode_box(level, box, ids);
  return ids;
}

std::array<float, 4> rgba_from_python(py::handle obj, const std::string& key) {
  std::vector<float> c;
  try {
    c = py::cast<std::vector<float>>(obj);
  } catch (const py::cast_error&) {
    c.clear();
  }
  if (c.size() != 4) throw py::value_error("colors[" + key + "]: expected (r, g, b, a), got " + std::string(py::repr(obj)));
  // NaN would spread through every node the label reaches; a double beyond float is infinite.
  for (const float v : c)
    if (!std::isfinite(v))
      throw py::value_error("colors[" + key + "]: expected four finite numbers (r, g, b, a), got " +
                            std::string(py::repr(obj)));
  return {c[0], c[1], c[2], c[3]};
}

// Per source id the RGBA the palette starts from: `colors` maps label values (and "default",
// for every label not listed, else transparent black) to (r, g, b, a), as the colour file of
// `strata labels palette` does. Labels that do not occur in the volume are ignored.
std::vector<float> source_colors(const mixture::LabelMap& map, const py::dict& colors) {
  std::array<float, 4> fallback{0, 0, 0, 0};
  for (const auto& [key, value] : colors)
    if (py::isinstance<py::str>(key) && py::cast<std::string>(key) == "default")
      fallback = rgba_from_python(value, "'default'");
  std::vector<float> src(std::size_t(map.size()) * 4);
  for (std::uint32_t i = 0; i < map.size(); ++i) std::copy(fallback.begin(), fallback.end(), src.begin() + 4 * i);
  for (const auto& [key, value] : colors) {
    if (py::isinstance<py::str>(key)) {
      if (py::cast<std::string>(key) == "default") continue;
      throw py::type_error("colors: keys are label values (integers) or \"default\", got " + std::string(py::repr(key)));
    }
    if (!py::isinstance<py::int_>(key) && !py::hasattr(key, "__index__"))
      throw py::type_error("colors: keys are label values (integers) or \"default\", got " + std::string(py::repr(key)));
    const std::int64_t label = index_from_python(key, "colors: label");
    const auto c = rgba_from_python(value, std::to_string(label));
    if (const auto id = map.id_of(label)) std::copy(c.begin(), c.end(), src.begin() + 4 * *id);
  }
  return src;
}

py::array_t<float> float_rows(std::vector<float> values, py::ssize_t columns) {
  auto* owner = new std::vector<float>(std::move(values));
  py::capsule base(owner, [](void* p) { delete static_cast<std::vector<float>*>(p); });
  return py::array_t<float>({py::ssize_t(owner->size()) / columns, columns}, owner->data(), base);
}

}  // namespace

void register_label_file(py::module_& m) {
  py::class_<LabelFile> cls(m, "LabelFile", R"(An encoded label volume (strata.open on a mixture-graph file).

lab[z0:z1, y0:y1, x0:x1] decodes the original labels (level 0, bit-exact); lab.level(l)[...] the
dominant label of each voxel of a coarser level; lab.query(box) the labels' voxel counts in a box
without decoding it.)");
  cls.def_property_readonly("path", [](const LabelFile& f) { return f.get()->path().string(); })
      .def_property_readonly("codec", [](const LabelFile& f) {
        f.get();
        return std::string(mixture::kMixtureCodecName);
      })
      .def_readonly("volume", &LabelFile::member, "The member of a volume set opened (None: the file itself).")
      .def_property_readonly("shape", [](const LabelFile& f) { return shape_of(f.get()->level_dims(0)); })
      .def_property_readonly("dtype", [](const LabelFile& f) { return numpy_dtype(f.get()->label_map().dtype()); })
      .def_property_readonly("spacing", [](const LabelFile& f) { return spacing_to_python(f.get()->spacing()); })
      .def_property_readonly(
          "affine", [](const LabelFile& f) { return affine_to_python(f.get()->geometry(), f.get()->spacing()); },
          "4x4 index-to-world transform of level 0 in array order: (z, y, x, 1) to world (z, y, x).")
      .def_property_readonly(
          "origin", [](const LabelFile& f) { return geometry_to_python(f.get()->geometry(), {})["origin"]; },
          "World position (z, y, x) of the centre of voxel 0.")
      .def_property_readonly("unit", [](const LabelFile& f) { return f.get()->geometry().unit; })
      .def_property_readonly("world_space",
                             [](const LabelFile& f) { return std::string(world_space_name(f.get()->geometry().space)); })
      .def_property_readonly("levels", [](const LabelFile& f) { return f.get()->level_count(); })
      .def_property_readonly("metadata", [](const LabelFile& f) { return json_to_python(f.get()->metadata()); })
      .def_property_readonly(
          "labels",
          [](const LabelFile& f) {
            const auto values = f.get()->label_map().values();
            return py::array_t<std::int64_t>(py::ssize_t(values.size()), values.data());
          },
          "The label values that occur, ascending (int64).")
      .def_property_readonly(
          "node_count", [](const LabelFile& f) { return f.get()->graph().node_count(); },
          "Nodes of the Mixture Graph: the rows of palette().")
      .def_property_readonly("has_normals", [](const LabelFile& f) { return f.get()->has_normals(); })
      .def(
          "level_shape",
          [](const LabelFile& f, int level) {
            const auto l = f.get();
            check_level(*l, level);
            return shape_of(l->level_dims(level));
          },
          py::arg("level"), "The (z, y, x) shape of a mip level.")
      .def(
          "read_dtype", [](const LabelFile& f, int, bool) { return numpy_dtype(f.get()->label_map().dtype()); },
          py::arg("level") = 0, py::arg("as_float") = false, "The sample type read() returns (the labels' own).")
      .def(
          "read",
          [](LabelFile& f, py::handle box, int level, bool as_float) {
            const auto l = f.get();
            check_level(*l, level);
            if (as_float) throw py::value_error("as_float: label files decode labels; lab.fraction(label) gives floats");
            const Box b = box_from_python(box, l->level_dims(level));
            Volume v;
            {
              py::gil_scoped_release release;
              std::vector<std::uint32_t> ids = node_ids(*l, level, b);
              // Level 0 nodes are the sources themselves; coarser ones show their dominant label.
              if (level > 0) {
                const auto& dominant = f.dominant_sources(*l);
                for (auto& id : ids) id = dominant[id];
              }
              v = l->label_map().decode(ids, b.size(), level_spacing(*l, level));
            }
            return to_numpy(std::move(v));
          },
          py::arg("box") = py::none(), py::kw_only(), py::arg("level") = 0, py::arg("as_float") = false,
          R"(The labels of a box of a level as a (z, y, x) array in the source's sample type: level 0 the
original labels, coarser levels the dominant label per voxel (as `strata labels decode`). box as
for ScalarFile.read.)")
      .def(
          "read_nodes",
          [](const LabelFile& f, py::handle box, int level) {
            const auto l = f.get();
            check_level(*l, level);
            const Box b = box_from_python(box, l->level_dims(level));
            Volume v(b.size(), DType::u32, level_spacing(*l, level));
            {
              py::gil_scoped_release release;
              const std::vector<std::uint32_t> ids = node_ids(*l, level, b);
              std::copy(ids.begin(), ids.end(), v.samples<std::uint32_t>().begin());
            }
            return to_numpy(std::move(v));
          },
          py::arg("box") = py::none(), py::kw_only(), py::arg("level") = 0,
          "The graph node of every voxel of a box (uint32): index palette() rows with it for colours.")
      .def(
          "query",
          [](const LabelFile& f, py::handle box, const std::string& method, std::uint64_t max_samples) {
            const auto l = f.get();
            const Box b = box_from_python(box, l->level_dims(0));
            mixture::QueryOptions options;
            options.method = mixture::parse_query_method(method);
            if (max_samples < 1) throw py::value_error("max_samples: must be at least 1");
            options.max_samples = max_samples;
            mixture::BoxHistogram h;
            {
              py::gil_scoped_release release;
              const mixture::BoxQuery query(*l, l->lookup(), l->graph().num_sources);
              h = query.run(b, options);
            }
            py::dict out;
            for (const mixture::BoxCount& c : h.counts)
              out[py::int_(l->label_map().value(c.source))] = py::make_tuple(c.count, c.sigma);
            return out;
          },
          py::arg("box") = py::none(), py::kw_only(), py::arg("method") = "hybrid",
          py::arg("max_samples") = mixture::QueryOptions{}.max_samples,
          R"(The histogram of the labels in a box of level 0, without decoding it (as `strata labels
query`): {label: (count, sigma)} in ascending label order, count the expected voxels and sigma its
standard deviation. method: "hybrid" (default), "footprint", "naive" (an exact scan) or "coarse"
(at most max_samples cells of one level).)")
      .def(
          "fraction",
          [](const LabelFile& f, std::int64_t label, int level) {
            const auto l = f.get();
            check_level(*l, level);
            Volume v;
            {
              py::gil_scoped_release release;
              v = l->label_fraction(level, label);
            }
            return to_numpy(std::move(v));
          },
          py::arg("label"), py::arg("level") = 0,
          "The fraction (float32, 0..1) of `label` in every voxel of a level (as `strata labels decode --label`).")
      .def(
          "palette",
          [](const LabelFile& f, const py::dict& colors) {
            const auto l = f.get();
            const std::vector<float> src = source_colors(l->label_map(), colors);
            std::vector<float> rgba;
            {
              py::gil_scoped_release release;
              rgba = mixture::propagate_palette(l->graph(), l->schedule(), src, 4);
            }
            return float_rows(std::move(rgba), 4);
          },
          py::arg("colors"),
          R"(Propagates per-label colours through the graph (as `strata labels palette`): colors maps
label values, and optionally "default", to (r, g, b, a); returns a (node_count, 4) float32 array, the
pre-filtered colour of every node, so palette[lab.read_nodes(box, level=l)] colours any box of any
level.)")
      .def("__repr__", [](const LabelFile& f) {
        if (!f.labels) return std::string("<strata.LabelFile (closed)>");
        const Extent d = f.labels->level_dims(0);
        return fmt::format("<strata.LabelFile '{}' shape=({}, {}, {}) {} levels={} labels={}>", f.labels->name(), d.z,
                           d.y, d.x, dtype_name(f.labels->label_map().dtype()), f.labels->level_count(),
                           f.labels->label_map().size());
      });
  add_file_protocol(cls, &LabelFile::labels);
}

}  // namespace strata::python
