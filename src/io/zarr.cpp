// Zarr v2 and v3 stores (folders) and OME-Zarr images (NGFF 0.4 and 0.5), read; OME-Zarr 0.4
// written (src/io/zarr/ome_zarr_writer.cpp). The array metadata and chunk codecs are in
// src/io/zarr/zarr_array.cpp, the chunked box reads in src/io/zarr/zarr_source.cpp.
//
// What a path opens (ReadOptions::dataset, a path inside the store, is appended first):
// | the folder holds                          | opens                                              |
// | ----------------------------------------- | -------------------------------------------------- |
// | `.zarray`, or `zarr.json` of an array     | that array (level must be 0)                       |
// | a group with `multiscales`                | datasets[level].path, with axes and transforms     |
// | a group without                           | its one array child; several: refused, listed      |
//
// OME-Zarr multiscales fields read (NGFF 0.4 `.zattrs`; 0.5 `zarr.json` attributes.ome):
// | field                                   | here                                                |
// | --------------------------------------- | --------------------------------------------------- |
// | axes[].name, type, unit                 | trailing "space" axes are z, y, x (or y, x); the    |
// |                                         | others (time, channel) are volumes, the first slowest |
// | datasets[].path                         | the array of each level, 0 the finest               |
// | datasets[].coordinateTransformations    | scale -> spacing, translation -> origin             |
// | coordinateTransformations (multiscale)  | applied after the dataset's (composed)              |
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "io/zarr/zarr_array.hpp"
#include "io/zarr/zarr_source.hpp"
#include "strata/core/error.hpp"
#include "io/zarr/ome_zarr_writer.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

bool is_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool looks_like_zarr(const fs::path& dir) {
  return is_file(dir / ".zarray") || is_file(dir / ".zgroup") || is_file(dir / "zarr.json") || is_file(dir / ".zattrs");
}

enum class NodeKind { array, group };

struct Node {
  NodeKind kind;
  json attributes;  // user attributes (v2 .zattrs, v3 zarr.json "attributes"); null when none
};

Node read_node(const fs::path& dir) {
  if (is_file(dir / ".zarray")) return {NodeKind::array, {}};
  if (is_file(dir / "zarr.json")) {
    const json j = read_zarr_json(dir / "zarr.json");
    const std::string file = (dir / "zarr.json").string();
    if (!j.contains("node_type") || !j["node_type"].is_string())
      throw FormatError(file, "node_type", "missing (expected \"array\" or \"group\")");
    const std::string type = j["node_type"].get<std::string>();
    if (type != "array" && type != "group")
      throw FormatError(file, "node_type", fmt::format("\"{}\" (expected array or group)", type));
    return {type == "array" ? NodeKind::array : NodeKind::group, j.value("attributes", json())};
  }
  if (is_file(dir / ".zgroup") || is_file(dir / ".zattrs"))
    return {NodeKind::group, is_file(dir / ".zattrs") ? read_zarr_json(dir / ".zattrs") : json()};
  throw FormatError(dir.string(), "metadata", "no .zarray, .zgroup, .zattrs or zarr.json: not a Zarr store");
}

// The `multiscales` list of a group's attributes (0.4 top level, 0.5 under "ome"), or null.
json multiscales_of(const json& attributes) {
  if (!attributes.is_object()) return {};
  if (attributes.contains("ome") && attributes["ome"].is_object() && attributes["ome"].contains("multiscales"))
    return attributes["ome"]["multiscales"];
  return attributes.value("multiscales", json());
}

// The transform an OME coordinateTransformations list makes, per axis: world = scale * i + translation.
struct AxisTransform {
  std::vector<double> scale, translation;
};

AxisTransform parse_transforms(const json& list, std::size_t rank, const std::string& file, const std::string& field) {
  AxisTransform t{std::vector<double>(rank, 1.0), std::vector<double>(rank, 0.0)};
  if (list.is_null()) return t;
  if (!list.is_array()) throw FormatError(file, field, "expected a list");
  for (const json& step : list) {
    const std::string type = step.is_object() && step.contains("type") && step["type"].is_string() ? step["type"].get<std::string>() : "";
    if (type == "identity") continue;
    if (type != "scale" && type != "translation")
      throw FormatError(file, field, fmt::format("{} is not read (expected scale or translation values)", step.dump()));
    const json& values = step.contains(type) ? step[type] : json();
    if (!values.is_array() || values.size() != rank || !std::all_of(values.begin(), values.end(), [](const json& v) { return v.is_number(); }))
      throw FormatError(file, field + "." + type, fmt::format("expected {} numbers, got {}", rank, values.dump()));
    for (std::size_t i = 0; i < rank; ++i) {
      const double v = values[i].get<double>();
      if (!std::isfinite(v) || (type == "scale" && v <= 0))
        throw FormatError(file, field + "." + type, fmt::format("{} is not a usable value", values.dump()));
      // Applied after what came before: a scale scales the translation so far.
      if (type == "scale") {
        t.scale[i] *= v;
        t.translation[i] *= v;
      } else {
        t.translation[i] += v;
      }
    }
  }
  return t;
}

// dataset transform, then the multiscale's.
AxisTransform compose(const AxisTransform& first, const AxisTransform& then) {
  AxisTransform t = first;
  for (std::size_t i = 0; i < t.scale.size(); ++i) {
    t.scale[i] = then.scale[i] * first.scale[i];
    t.translation[i] = then.scale[i] * first.translation[i] + then.translation[i];
  }
  return t;
}

struct Axis {
  std::string name, type, unit;
};

std::vector<Axis> parse_axes(const json& multiscale, std::size_t rank, const std::string& file) {
  std::vector<Axis> axes;
  const json list = multiscale.value("axes", json());
  if (list.is_null()) {  // NGFF 0.1, 0.2: always t, c, z, y, x, the trailing `rank` of them
    const char* names[] = {"t", "c", "z", "y", "x"};
    for (std::size_t i = 5 - std::min<std::size_t>(rank, 5); i < 5; ++i) axes.push_back({names[i], "", ""});
  } else if (list.is_array()) {
    for (const json& a : list) {
      if (a.is_string()) axes.push_back({a.get<std::string>(), "", ""});  // NGFF 0.3: names only
      else if (a.is_object() && a.contains("name") && a["name"].is_string())
        axes.push_back({a["name"].get<std::string>(), a.value("type", ""), a.value("unit", "")});
      else throw FormatError(file, "multiscales.axes", fmt::format("{} has no name", a.dump()));
    }
  }
  if (axes.size() != rank)
    throw FormatError(file, "multiscales.axes", fmt::format("{} axes for an array of {} dimensions", axes.size(), rank));
  for (Axis& a : axes)
    if (a.type.empty()) a.type = a.name == "x" || a.name == "y" || a.name == "z" ? "space" : a.name == "t" ? "time" : "channel";
  return axes;
}

std::int64_t trailing_space_axes(const std::vector<Axis>& axes, const std::string& file) {
  std::int64_t n = 0;
  for (auto it = axes.rbegin(); it != axes.rend() && it->type == "space"; ++it) ++n;
  const auto all = std::count_if(axes.begin(), axes.end(), [](const Axis& a) { return a.type == "space"; });
  if (n < 2 || n > 3 || all != n)
    throw FormatError(file, "multiscales.axes",
                      "expected 2 or 3 space axes after the time and channel axes (t, c, z, y, x order)");
  return n;
}

// What the caller's choices and the file make of an array: the view and the info.
struct Opened {
  ZarrArray array;
  ZarrView view;
  VolumeInfo info;
};

// dims, dtype, volumes and the volume's leading index of `array` read with `spatial` space axes.
Opened view_array(ZarrArray array, int spatial, const ReadOptions& options) {
  Opened o;
  const std::size_t rank = array.shape.size();
  const std::size_t leading = rank - std::size_t(spatial);
  const std::int64_t x = array.shape[rank - 1], y = array.shape[rank - 2], z = spatial == 3 ? array.shape[rank - 3] : 1;
  o.info.dims = {x, y, z};
  o.info.dtype = array.dtype;
  for (std::size_t i = 0; i < leading; ++i) o.info.volumes *= array.shape[i];  // the byte count was checked
  const std::int64_t volume = choose_volume(o.info.volumes, o.info.dims, options, array.metadata_file, "shape",
                                            "the leading (time, channel) axes, the first slowest");
  o.view.spatial = spatial;
  o.view.leading_index.assign(leading, 0);
  std::int64_t rest = volume;
  for (std::size_t i = leading; i-- > 0;) {
    o.view.leading_index[i] = rest % array.shape[i];
    rest /= array.shape[i];
  }
  o.array = std::move(array);
  return o;
}

Opened open_plain_array(const fs::path& dir, const ReadOptions& options) {
  ZarrArray array = parse_zarr_array(dir);
  const int spatial = int(std::min<std::size_t>(array.shape.size(), 3));
  return view_array(std::move(array), spatial, options);
}

std::int64_t choose_level(const json& datasets, const ReadOptions& options, const std::string& file) {
  if (!datasets.is_array() || datasets.empty()) throw FormatError(file, "multiscales.datasets", "expected a non-empty list");
  const std::int64_t level = options.level.value_or(0), count = std::int64_t(datasets.size());
  if (level < 0 || level >= count)
    throw ParameterError("ReadOptions::level",
                         fmt::format("{}: level {} does not exist; the image has {} (0..{})", file, level, count, count - 1));
  return level;
}

fs::path dataset_dir(const fs::path& group, const json& dataset, const std::string& file) {
  const std::string path = dataset.is_object() && dataset.contains("path") && dataset["path"].is_string()
                               ? dataset["path"].get<std::string>()
                               : throw FormatError(file, "multiscales.datasets.path", "missing");
  const fs::path relative(path);
  if (path.empty() || relative.is_absolute() ||
      std::any_of(relative.begin(), relative.end(), [](const fs::path& part) { return part == ".."; }))
    throw FormatError(file, "multiscales.datasets.path", fmt::format("\"{}\" is not a path inside the image", path));
  return group / relative;
}

Opened open_multiscale(const fs::path& group, const json& multiscales, const ReadOptions& options, const std::string& file) {
  if (!multiscales.is_array() || multiscales.empty() || !multiscales[0].is_object())
    throw FormatError(file, "multiscales", "expected a list of multiscale objects");
  const json& ms = multiscales[0];  // the first is the image itself (NGFF)
  const json& datasets = ms.contains("datasets") ? ms["datasets"] : json();
  const std::int64_t level = choose_level(datasets, options, file);
  const json& dataset = datasets[std::size_t(level)];
  ZarrArray array = parse_zarr_array(dataset_dir(group, dataset, file));
  const std::size_t rank = array.shape.size();
  const std::vector<Axis> axes = parse_axes(ms, rank, file);
  const int spatial = int(trailing_space_axes(axes, file));
  const AxisTransform t =
      compose(parse_transforms(dataset.value("coordinateTransformations", json()), rank, file,
                               "multiscales.datasets.coordinateTransformations"),
              parse_transforms(ms.value("coordinateTransformations", json()), rank, file, "multiscales.coordinateTransformations"));
  Opened o = view_array(std::move(array), spatial, options);
  // Index axis a (0 x, 1 y, 2 z) is array axis rank - 1 - a.
  double spacing[3] = {1, 1, 1};
  for (int a = 0; a < spatial; ++a) {
    const std::size_t axis = rank - 1 - std::size_t(a);
    spacing[a] = t.scale[axis];
    o.info.geometry.origin[std::size_t(a)] = t.translation[axis];
  }
  o.info.spacing = {spacing[0], spacing[1], spacing[2]};
  o.info.geometry.unit = canonical_length_unit(axes[rank - 1].unit);
  return o;
}

// The names of the arrays directly inside a group, for choosing one.
std::vector<std::string> child_arrays(const fs::path& group) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(group, ec))
    if (entry.is_directory(ec) && (is_file(entry.path() / ".zarray") || is_file(entry.path() / "zarr.json")))
      try {
        if (read_node(entry.path()).kind == NodeKind::array) names.push_back(entry.path().filename().string());
      } catch (const FormatError&) {
        // a damaged sibling is reported when it is chosen, not when another one is
      }
  std::sort(names.begin(), names.end());
  return names;
}

fs::path node_path(const fs::path& store, const std::string& dataset) {
  std::string inner = dataset;
  while (!inner.empty() && inner.front() == '/') inner.erase(inner.begin());
  const fs::path relative(inner);
  if (std::any_of(relative.begin(), relative.end(), [](const fs::path& part) { return part == ".."; }))
    throw ParameterError("ReadOptions::dataset", fmt::format("\"{}\" leaves the store {}", dataset, store.string()));
  return inner.empty() ? store : store / relative;
}

Opened open_node(const fs::path& store, const ReadOptions& options) {
  const fs::path dir = node_path(store, options.dataset);
  const Node node = read_node(dir);
  const std::string file = dir.string();
  const json multiscales = multiscales_of(node.attributes);
  if (node.kind == NodeKind::group && !multiscales.is_null()) return open_multiscale(dir, multiscales, options, file);
  if (options.level.value_or(0) != 0)
    throw ParameterError("ReadOptions::level", fmt::format("{}: not a multiscale image (no OME-Zarr multiscales)", file));
  if (node.kind == NodeKind::array) return open_plain_array(dir, options);
  const std::vector<std::string> arrays = child_arrays(dir);
  if (arrays.size() == 1) return open_plain_array(dir / arrays[0], options);
  throw FormatError(file, "dataset",
                    arrays.empty() ? std::string("a group without multiscales or arrays")
                                   : fmt::format("a group of {} arrays ({}); choose one with --dataset", arrays.size(),
                                                 fmt::join(arrays, ", ")));
}

std::unique_ptr<VolumeSource> open_zarr(const fs::path& path, const ReadOptions& options) {
  Opened o = open_node(path, options);
  return make_zarr_source(std::move(o.array), std::move(o.view), std::move(o.info), path);
}

std::unique_ptr<VolumeWriter> create_zarr_writer(const fs::path& path, const VolumeInfo& info, const WriteOptions& options) {
  return make_ome_zarr_writer(path, info, options);
}

}  // namespace

VolumeFormat zarr_format() {
  return {
      .name = "zarr",
      .title = "Zarr, OME-Zarr",
      .description = "chunked arrays in a folder (Zarr v2 and v3), and OME-Zarr multiscale images (NGFF 0.4, 0.5)",
      .extensions = {".zarr", ".ome.zarr"},
      .directory = "a Zarr store (.zarray, .zgroup, .zattrs or zarr.json)",
      .sniff_directory = looks_like_zarr,
      .open = open_zarr,
      .create_writer = create_zarr_writer,
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true, .datasets = true,
                       .multiscale = true},
      .write_dtypes = DTypeSet::all(),
      .read_notes = "Zarr v2 and v3 (regular chunks; C or F order, transpose; compressors gzip, zlib, zstd, blosc "
                    "with lz4/zstd/zlib/blosclz and shuffle/bitshuffle; crc32c; fill values; missing chunks; either "
                    "byte order); OME-Zarr 0.4/0.5 multiscales: --level, axes units, scale and translation; t/c axes "
                    "as --volume; --dataset for an array in a group; chunks decoded as boxes need them",
      .write_notes = "OME-Zarr 0.4 (Zarr v2, 64^3 chunks, blosc-zstd or uncompressed, \"/\" keys) with scale, "
                     "translation and unit; direction cosines are not written (NGFF has none); every level of a "
                     ".strata file through io::write_ome_zarr_pyramid",
  };
}

}  // namespace strata::io::detail
