// Zarr v2 and v3 stores (folders and zip files) and OME-Zarr images (NGFF 0.4 and 0.5), read;
// OME-Zarr 0.4 written (src/io/zarr/ome_zarr_writer.cpp). The stores are in
// src/io/zarr/zarr_store.cpp and zip_store.cpp, the array metadata and chunk codecs in
// zarr_array.cpp, shards in zarr_chunk_reader.cpp, the chunked box reads in zarr_source.cpp.
//
// What a path opens (ReadOptions::dataset, a path inside the store, is appended first):
// | the store (folder or zip) holds           | opens                                              |
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
#include "io/zarr/ome_zarr_writer.hpp"
#include "io/zarr/zarr_source.hpp"
#include "io/zarr/zarr_store.hpp"
#include "strata/core/error.hpp"

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

// The same question of a store on a web server: one request when it is an OME-Zarr v2 image.
// No for a URL with a query (a presigned object: keys cannot be appended to it). A server that
// cannot be reached, or refuses (403), is an Error naming the URL of the key asked for.
bool url_is_zarr(const std::string& url) {
  if (url.find_first_of("?#") != std::string::npos) return false;
  const auto store = open_zarr_store(url);
  return store->exists(".zattrs") || store->exists("zarr.json") || store->exists(".zarray") || store->exists(".zgroup");
}

enum class NodeKind { array, group };

struct Node {
  NodeKind kind;
  json attributes;  // user attributes (v2 .zattrs, v3 zarr.json "attributes"); null when none
};

// The store and the key of one of its nodes ("" for the root).
struct Place {
  std::shared_ptr<const ZarrStore> store;
  std::string node;
  std::string key(const std::string& name) const { return join_key(node, name); }
  std::string file() const { return store->name(node); }
};

Node read_node(const Place& at) {
  const ZarrStore& store = *at.store;
  if (store.exists(at.key(".zarray"))) return {NodeKind::array, {}};
  if (store.exists(at.key("zarr.json"))) {
    const json j = read_zarr_json(store, at.key("zarr.json"));
    const std::string file = store.name(at.key("zarr.json"));
    if (!j.contains("node_type") || !j["node_type"].is_string())
      throw FormatError(file, "node_type", "missing (expected \"array\" or \"group\")");
    const std::string type = j["node_type"].get<std::string>();
    if (type != "array" && type != "group")
      throw FormatError(file, "node_type", fmt::format("\"{}\" (expected array or group)", type));
    return {type == "array" ? NodeKind::array : NodeKind::group, j.value("attributes", json())};
  }
  const bool has_attributes = store.exists(at.key(".zattrs"));
  if (store.exists(at.key(".zgroup")) || has_attributes)
    return {NodeKind::group, has_attributes ? read_zarr_json(store, at.key(".zattrs")) : json()};
  throw FormatError(at.file(), "metadata", "no .zarray, .zgroup, .zattrs or zarr.json: not a Zarr store");
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

Opened open_plain_array(const Place& at, const ReadOptions& options) {
  ZarrArray array = parse_zarr_array(at.store, at.node);
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

// "a//b/./c" -> "a/b/c"; nothing when a part is ".." (it would leave the store).
std::optional<std::string> relative_key(const std::string& path) {
  std::string key;
  for (const fs::path& part : fs::path(path)) {
    const std::string p = part.string();
    if (p == "..") return std::nullopt;
    if (p.empty() || p == "." || p == "/") continue;
    key = join_key(key, p);
  }
  return key;
}

Place dataset_place(const Place& group, const json& dataset, const std::string& file) {
  const std::string path = dataset.is_object() && dataset.contains("path") && dataset["path"].is_string()
                               ? dataset["path"].get<std::string>()
                               : throw FormatError(file, "multiscales.datasets.path", "missing");
  const std::optional<std::string> key = relative_key(path);
  if (path.empty() || fs::path(path).is_absolute() || !key || key->empty())
    throw FormatError(file, "multiscales.datasets.path", fmt::format("\"{}\" is not a path inside the image", path));
  return {group.store, group.key(*key)};
}

Opened open_multiscale(const Place& group, const json& multiscales, const ReadOptions& options, const std::string& file) {
  if (!multiscales.is_array() || multiscales.empty() || !multiscales[0].is_object())
    throw FormatError(file, "multiscales", "expected a list of multiscale objects");
  const json& ms = multiscales[0];  // the first is the image itself (NGFF)
  const json& datasets = ms.contains("datasets") ? ms["datasets"] : json();
  const std::int64_t level = choose_level(datasets, options, file);
  const json& dataset = datasets[std::size_t(level)];
  const Place level_array = dataset_place(group, dataset, file);
  ZarrArray array = parse_zarr_array(level_array.store, level_array.node);
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
std::vector<std::string> child_arrays(const Place& group) {
  std::vector<std::string> names;
  for (const std::string& child : group.store->children(group.node)) {
    const Place at{group.store, group.key(child)};
    if (at.store->exists(at.key(".zarray")) || at.store->exists(at.key("zarr.json")))
      try {
        if (read_node(at).kind == NodeKind::array) names.push_back(child);
      } catch (const FormatError&) {
        // a damaged sibling is reported when it is chosen, not when another one is
      }
  }
  return names;
}

Place node_place(const fs::path& path, const std::string& dataset) {
  const std::optional<std::string> key = relative_key(dataset);
  if (!key) throw ParameterError("ReadOptions::dataset", fmt::format("\"{}\" leaves the store {}", dataset, path.string()));
  return {open_zarr_store(path), *key};
}

Opened open_node(const fs::path& path, const ReadOptions& options) {
  const Place at = node_place(path, options.dataset);
  const Node node = read_node(at);
  const std::string file = at.file();
  const json multiscales = multiscales_of(node.attributes);
  if (node.kind == NodeKind::group && !multiscales.is_null()) return open_multiscale(at, multiscales, options, file);
  if (options.level.value_or(0) != 0)
    throw ParameterError("ReadOptions::level", fmt::format("{}: not a multiscale image (no OME-Zarr multiscales)", file));
  if (node.kind == NodeKind::array) return open_plain_array(at, options);
  if (!at.store->listable())
    throw FormatError(file, "dataset",
                      "a group without OME-Zarr multiscales, on a web server that cannot list it: name the array "
                      "with --dataset");
  const std::vector<std::string> arrays = child_arrays(at);
  if (arrays.size() == 1) return open_plain_array({at.store, at.key(arrays[0])}, options);
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
  if (is_zip_store_name(path))
    throw Error(fmt::format("{}: zip stores are read, not written; write a .zarr or .ome.zarr folder (and zip it "
                            "with no compression if a zip is needed)",
                            path.string()));
  return make_ome_zarr_writer(path, info, options);
}

}  // namespace

VolumeFormat zarr_format() {
  return {
      .name = "zarr",
      .title = "Zarr, OME-Zarr",
      .description = "chunked arrays in a folder or a zip file (Zarr v2 and v3), and OME-Zarr multiscale images "
                     "(NGFF 0.4, 0.5)",
      .extensions = {".zarr", ".ome.zarr", ".zarr.zip", ".ome.zarr.zip"},
      .directory = "a Zarr store (.zarray, .zgroup, .zattrs or zarr.json)",
      .sniff_directory = looks_like_zarr,
      .sniff_url = url_is_zarr,
      .open = open_zarr,
      .create_writer = create_zarr_writer,
      .files_written = [](const fs::path& path, const WriteOptions&) { return replaced_folder_written(path); },
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true, .datasets = true,
                       .multiscale = true},
      .write_dtypes = DTypeSet::all(),
      .read_notes = "Zarr v2 and v3 (regular chunks; C or F order, transpose; compressors gzip, zlib, zstd, blosc "
                    "with lz4/zstd/zlib/blosclz and shuffle/bitshuffle; crc32c; fill values; missing chunks; either "
                    "byte order; v3 sharding_indexed, inner chunks read by range); folders, zip stores (stored or "
                    "deflated members, zip64) or http(s) URLs (e.g. `strata serve`'s /zarr/<name>); OME-Zarr 0.4/0.5 multiscales: --level, axes units, scale and translation; t/c axes "
                    "as --volume; --dataset for an array in a group; chunks decoded as boxes need them",
      .write_notes = "OME-Zarr 0.4 (Zarr v2, 64^3 chunks, blosc-zstd or uncompressed, \"/\" keys) with scale, "
                     "translation and unit; direction cosines are not written (NGFF has none); every level of a "
                     ".strata file through io::write_ome_zarr_pyramid; no zip stores",
  };
}

}  // namespace strata::io::detail
