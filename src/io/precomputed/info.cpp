// Reading, checking and writing the `info` file of a Neuroglancer precomputed volume.
//
// Members read (volume.md, sharded.md of Neuroglancer's precomputed data source):
// | member                                      | type            | here                                   |
// | ------------------------------------------- | --------------- | -------------------------------------- |
// | @type                                       | string          | "neuroglancer_multiscale_volume" if set|
// | type                                        | string          | "image" or "segmentation"              |
// | data_type                                   | string          | uint8..uint64, int8..int32, float32    |
// | num_channels                                | integer         | volumes of the file (channels)         |
// | scales[i].key                               | string          | the scale's folder (relative, no "..") |
// | scales[i].size                              | 3 integers      | dims                                   |
// | scales[i].voxel_offset                      | 3 integers      | origin = voxel_offset * resolution     |
// | scales[i].resolution                        | 3 numbers       | spacing in nm                          |
// | scales[i].chunk_sizes[0]                    | 3 integers      | the chunk grid                         |
// | scales[i].encoding                          | string          | raw, jpeg, compressed_segmentation     |
// | scales[i].compressed_segmentation_block_size| 3 integers      | block of the lookup tables             |
// | scales[i].sharding                          | object          | ShardingSpec (absent: unsharded)       |
#include "io/precomputed/info.hpp"

#include <cmath>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/io/files.hpp"

namespace strata::io::detail::precomputed {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr std::string_view kVolumeType = "neuroglancer_multiscale_volume";
constexpr std::string_view kShardingType = "neuroglancer_uint64_sharded_v1";
// Coordinates beyond this are refused: offsets, sizes and chunk ends then never overflow.
constexpr std::int64_t kMaxCoordinate = std::int64_t(1) << 48;
constexpr std::int64_t kMaxChannels = 4096;

struct DataType {
  const char* name;
  DType dtype;
};
constexpr DataType kDataTypes[] = {{"uint8", DType::u8},   {"int8", DType::i8},    {"uint16", DType::u16},
                                   {"int16", DType::i16},  {"uint32", DType::u32}, {"int32", DType::i32},
                                   {"uint64", DType::u64}, {"float32", DType::f32}};

// The deepest nesting of arrays and objects in `text`, skipping strings.
int json_depth(std::string_view text) {
  int depth = 0, deepest = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

// The parsed info file, its size and nesting bounded first.
json parse_bounded_json(const fs::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  const std::uintmax_t bytes = fs::file_size(path, ec);
  if (ec) throw Error(fmt::format("{}: cannot read: {}", file, ec.message()));
  if (bytes > kMaxInfoBytes)
    throw FormatError(file, "info",
                      fmt::format("{} bytes, more than the {} an info file may have", bytes, kMaxInfoBytes));
  std::ifstream in(path, std::ios::binary);
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (json_depth(text) > kMaxJsonDepth)
    throw FormatError(file, "info", fmt::format("JSON nested deeper than {} levels", kMaxJsonDepth));
  try {
    return json::parse(text);
  } catch (const json::exception& e) {
    throw FormatError(file, "info", "invalid JSON: " + json_error_reason(e));
  }
}

// Field access that names the member in every error.
class Fields {
 public:
  Fields(std::string file, const json& object, std::string prefix)
      : file_(std::move(file)), object_(object), prefix_(std::move(prefix)) {}

  [[noreturn]] void fail(std::string_view member, const std::string& problem) const {
    throw FormatError(file_, prefix_ + std::string(member), problem);
  }
  const json* find(std::string_view member) const {
    const auto it = object_.find(member);
    return it == object_.end() ? nullptr : &*it;
  }
  const json& required(std::string_view member) const {
    const json* value = find(member);
    if (!value) fail(member, "missing");
    return *value;
  }
  std::string string(std::string_view member) const {
    const json& value = required(member);
    if (!value.is_string()) fail(member, "must be a string");
    return value.get<std::string>();
  }
  std::string string_or(std::string_view member, std::string fallback) const {
    return find(member) ? string(member) : fallback;
  }
  std::int64_t integer(std::string_view member, std::int64_t lo, std::int64_t hi) const {
    return bounded(member, required(member), lo, hi);
  }
  std::int64_t integer_or(std::string_view member, std::int64_t fallback, std::int64_t lo, std::int64_t hi) const {
    return find(member) ? integer(member, lo, hi) : fallback;
  }
  Extent triple(std::string_view member, const json& value, std::int64_t lo, std::int64_t hi) const {
    if (!value.is_array() || value.size() != 3) fail(member, "must be an array of 3 integers");
    return {bounded(member, value[0], lo, hi), bounded(member, value[1], lo, hi), bounded(member, value[2], lo, hi)};
  }
  Extent triple(std::string_view member, std::int64_t lo, std::int64_t hi) const {
    return triple(member, required(member), lo, hi);
  }
  // The fields of the object `member` (its errors name "<prefix><member>.<field>").
  Fields nested(std::string_view member, const json& value) const {
    if (!value.is_object()) fail(member, "must be an object");
    return Fields(file_, value, prefix_ + std::string(member) + ".");
  }
  std::array<double, 3> positive_numbers(std::string_view member) const {
    const json& value = required(member);
    if (!value.is_array() || value.size() != 3) fail(member, "must be an array of 3 numbers");
    std::array<double, 3> out{};
    for (std::size_t i = 0; i < 3; ++i) {
      if (!value[i].is_number()) fail(member, "must be an array of 3 numbers");
      out[i] = value[i].get<double>();
      if (!std::isfinite(out[i]) || out[i] <= 0)
        fail(member, fmt::format("{} is not a positive size", value[i].dump()));
    }
    return out;
  }

 private:
  std::int64_t bounded(std::string_view member, const json& value, std::int64_t lo, std::int64_t hi) const {
    if (!value.is_number_integer()) fail(member, fmt::format("{} is not an integer", value.dump()));
    const bool negative = value.is_number_unsigned() ? false : value.get<std::int64_t>() < 0;
    const std::int64_t v =
        negative ? value.get<std::int64_t>()
                 : std::int64_t(std::min<std::uint64_t>(value.get<std::uint64_t>(), std::uint64_t(hi) + 1));
    if (v < lo || v > hi) fail(member, fmt::format("{} is outside {}..{}", value.dump(), lo, hi));
    return v;
  }

  std::string file_;
  const json& object_;
  std::string prefix_;
};

// A key is a folder inside the volume's: relative, without "..".
void check_key(const Fields& f, const std::string& key) {
  if (key.empty() || key.front() == '/') f.fail("key", fmt::format("\"{}\" is not a relative folder name", key));
  for (const auto& part : fs::path(key))
    if (part == "..") f.fail("key", fmt::format("\"{}\" leaves the volume's folder", key));
}

// The bytes of `count` channels of a chunk, or nothing past kMaxChunkBytes (or 64 bits).
std::optional<std::uint64_t> chunk_bytes(const Extent& chunk, DType dtype, std::int64_t count) {
  const std::optional<std::int64_t> voxels = chunk.checked_voxel_count();
  if (!voxels || std::uint64_t(*voxels) > kMaxChunkBytes / dtype_size(dtype) / std::uint64_t(count))
    return std::nullopt;
  return std::uint64_t(*voxels) * dtype_size(dtype) * std::uint64_t(count);
}

ShardingSpec parse_sharding(const Fields& scale, const json& value) {
  const Fields f = scale.nested("sharding", value);
  if (f.string_or("@type", std::string(kShardingType)) != kShardingType)
    f.fail("@type", fmt::format("expected \"{}\"", kShardingType));
  ShardingSpec s;
  s.preshift_bits = int(f.integer_or("preshift_bits", 0, 0, 64));
  const std::string hash = f.string("hash");
  if (hash != "identity" && hash != "murmurhash3_x86_128")
    f.fail("hash", fmt::format("\"{}\" (expected identity or murmurhash3_x86_128)", hash));
  s.murmurhash = hash == "murmurhash3_x86_128";
  s.minishard_bits = int(f.integer("minishard_bits", 0, 32));
  s.shard_bits = int(f.integer("shard_bits", 0, 64 - s.minishard_bits));
  const auto gzip = [&](std::string_view member) {
    const std::string e = f.string_or(member, "raw");
    if (e != "raw" && e != "gzip") f.fail(member, fmt::format("\"{}\" (expected raw or gzip)", e));
    return e == "gzip";
  };
  s.gzip_minishard_index = gzip("minishard_index_encoding");
  s.gzip_data = gzip("data_encoding");
  return s;
}

ChunkEncoding parse_encoding(const Fields& f, const VolumeDescription& d) {
  const std::string name = f.string("encoding");
  if (name == "raw") return ChunkEncoding::raw;
  if (name == "jpeg") {
    if (d.dtype != DType::u8 || (d.channels != 1 && d.channels != 3))
      f.fail("encoding", "jpeg needs data_type uint8 and 1 or 3 channels");
    return ChunkEncoding::jpeg;
  }
  if (name == "compressed_segmentation") {
    if (d.dtype != DType::u32 && d.dtype != DType::u64)
      f.fail("encoding", "compressed_segmentation needs data_type uint32 or uint64");
    return ChunkEncoding::compressed_segmentation;
  }
  f.fail("encoding", fmt::format("\"{}\" (expected raw, jpeg or compressed_segmentation)", name));
}

Scale parse_scale(const std::string& file, const json& value, std::size_t index, const VolumeDescription& d) {
  const std::string prefix = fmt::format("scales[{}].", index);
  if (!value.is_object()) throw FormatError(file, prefix.substr(0, prefix.size() - 1), "must be an object");
  const Fields f(file, value, prefix);
  Scale s;
  s.key = f.string("key");
  check_key(f, s.key);
  s.size = f.triple("size", 1, kMaxCoordinate);
  s.voxel_offset = f.find("voxel_offset") ? f.triple("voxel_offset", -kMaxCoordinate, kMaxCoordinate) : Extent{};
  s.resolution = f.positive_numbers("resolution");
  const json& chunks = f.required("chunk_sizes");
  if (!chunks.is_array() || chunks.empty()) f.fail("chunk_sizes", "must be a non-empty array of [x, y, z] sizes");
  s.chunk = f.triple("chunk_sizes", chunks[0], 1, kMaxCoordinate);
  if (!chunk_bytes(s.chunk, d.dtype, d.channels))
    f.fail("chunk_sizes", fmt::format("chunks of {} x {} channels of {} exceed {} bytes", s.chunk.to_string(),
                                      d.channels, dtype_name(d.dtype), kMaxChunkBytes));
  s.encoding = parse_encoding(f, d);
  if (s.encoding == ChunkEncoding::compressed_segmentation) {
    if (const json* block = f.find("compressed_segmentation_block_size"))
      s.block = f.triple("compressed_segmentation_block_size", *block, 1, 1 << 16);
    if (!chunk_bytes(s.block, d.dtype, 1))
      f.fail("compressed_segmentation_block_size", "blocks larger than a chunk may be");
  }
  if (const json* sharding = f.find("sharding"); sharding && !sharding->is_null())
    s.sharding = parse_sharding(f, *sharding);
  return s;
}

}  // namespace

const char* data_type_name(DType dtype) {
  for (const DataType& t : kDataTypes)
    if (t.dtype == dtype) return t.name;
  return nullptr;
}

VolumeDescription read_info(const fs::path& folder) {
  const fs::path path = folder / "info";
  const std::string file = path.string();
  const json root = parse_bounded_json(path);
  if (!root.is_object()) throw FormatError(file, "info", "must be a JSON object");
  const Fields f(file, root, "");
  if (f.string_or("@type", std::string(kVolumeType)) != kVolumeType)
    f.fail("@type", fmt::format("expected \"{}\"", kVolumeType));
  VolumeDescription d;
  const std::string type = f.string("type");
  if (type != "image" && type != "segmentation")
    f.fail("type", fmt::format("\"{}\" (expected image or segmentation)", type));
  d.segmentation = type == "segmentation";
  const std::string data_type = f.string("data_type");
  const auto known = std::find_if(std::begin(kDataTypes), std::end(kDataTypes),
                                  [&](const DataType& t) { return data_type == t.name; });
  if (known == std::end(kDataTypes))
    f.fail("data_type", fmt::format("\"{}\" is not a sample type Strata reads", data_type));
  d.dtype = known->dtype;
  d.channels = f.integer_or("num_channels", 1, 1, kMaxChannels);
  const json& scales = f.required("scales");
  if (!scales.is_array() || scales.empty()) f.fail("scales", "must be a non-empty array");
  for (std::size_t i = 0; i < scales.size(); ++i) d.scales.push_back(parse_scale(file, scales[i], i, d));
  return d;
}

bool looks_like_precomputed(const fs::path& folder) {
  std::error_code ec;
  const fs::path path = folder / "info";
  if (!fs::is_regular_file(path, ec) || fs::file_size(path, ec) > kMaxInfoBytes || ec) return false;
  try {
    const json root = parse_bounded_json(path);
    return root.is_object() && (root.value("@type", "") == kVolumeType || root.contains("scales"));
  } catch (const std::exception&) {
    return false;
  }
}

json info_json(const VolumeDescription& d) {
  json scales = json::array();
  for (const Scale& s : d.scales) {
    json scale = {{"key", s.key},
                  {"size", {s.size.x, s.size.y, s.size.z}},
                  {"voxel_offset", {s.voxel_offset.x, s.voxel_offset.y, s.voxel_offset.z}},
                  {"resolution", {s.resolution[0], s.resolution[1], s.resolution[2]}},
                  {"chunk_sizes", {{s.chunk.x, s.chunk.y, s.chunk.z}}}};
    switch (s.encoding) {
      case ChunkEncoding::raw: scale["encoding"] = "raw"; break;
      case ChunkEncoding::jpeg: scale["encoding"] = "jpeg"; break;
      case ChunkEncoding::compressed_segmentation:
        scale["encoding"] = "compressed_segmentation";
        scale["compressed_segmentation_block_size"] = {s.block.x, s.block.y, s.block.z};
        break;
    }
    scales.push_back(std::move(scale));
  }
  return {{"@type", kVolumeType},
          {"type", d.segmentation ? "segmentation" : "image"},
          {"data_type", data_type_name(d.dtype)},
          {"num_channels", d.channels},
          {"scales", std::move(scales)}};
}

}  // namespace strata::io::detail::precomputed
