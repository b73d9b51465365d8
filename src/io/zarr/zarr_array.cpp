// Zarr array metadata and chunk decoding, v2 and v3.
//
// `.zarray` (Zarr v2) fields read:
// | field               | type                         | here                                          |
// | ------------------- | ---------------------------- | --------------------------------------------- |
// | zarr_format         | 2                            | checked                                       |
// | shape, chunks       | int[n], n = 2..5             | C order, the last axis x; edge chunks whole    |
// | dtype               | "<u2", ">f4", "|u1", ...     | ten sample types, either byte order            |
// | compressor          | null or {"id": ...}          | gzip, zlib, zstd, blosc (lz4, zstd, zlib, ...) |
// | fill_value          | number, "NaN", null          | the samples of a missing chunk                 |
// | order               | "C" or "F"                   | F: the chunk's axes stored reversed            |
// | filters             | null or []                   | others refused                                 |
// | dimension_separator | "." or "/"                   | chunk key "i.j.k" or "i/j/k"                   |
//
// `zarr.json` (Zarr v3, node_type "array") fields read:
// | field              | value                                   | here                                  |
// | ------------------ | --------------------------------------- | ------------------------------------- |
// | shape, data_type   | int[n], "uint16", "float32", ...        | as v2                                 |
// | chunk_grid         | regular, configuration.chunk_shape      | the only grid                         |
// | chunk_key_encoding | default ("c/i/j/k") or v2 ("i.j.k")     | configuration.separator               |
// | fill_value         | number, "NaN", "Infinity", "0x7fc00000" | as v2; hex: the float's bits          |
// | codecs             | transpose, bytes, gzip, zstd, blosc,    | array-to-array, array-to-bytes, then  |
// |                    | crc32c; or sharding_indexed alone       | bytes-to-bytes                        |
//
// `sharding_indexed` configuration (the chunk grid's cells are then shards):
// | field          | value                                      | here                                 |
// | -------------- | ------------------------------------------ | ------------------------------------ |
// | chunk_shape    | int[n], dividing the shard shape            | the inner chunks, what is decoded     |
// | codecs         | as above, but no sharding_indexed           | the inner chunks' codecs (nested      |
// |                |                                            | sharding refused)                    |
// | index_codecs   | bytes (either endian), then crc32c or none | the index: per inner chunk (C order)  |
// |                |                                            | u64 offset, u64 nbytes; ~0 both=empty |
// | index_location | "end" (default) or "start"                 | where the index sits in the shard     |
#include "io/zarr/zarr_array.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include <blosc.h>
#include <fmt/format.h>
#include <zstd.h>
#include <zstd_errors.h>

#include "io/io_detail.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/checked.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail {

namespace {

using nlohmann::json;

// Deepest nesting of `text`'s arrays and objects, counted outside strings, stopping once it
// passes `limit`: a recursive document is refused before the parser sees it.
int json_depth(std::string_view text, int limit) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (char c : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) break;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

// Field access that names the missing or mistyped field.
struct Fields {
  const json& j;
  const std::string& file;

  const json& at(const std::string& name) const {
    if (!j.is_object() || !j.contains(name)) throw FormatError(file, name, "missing");
    return j.at(name);
  }
  std::string text(const std::string& name) const {
    const json& v = at(name);
    if (!v.is_string()) throw FormatError(file, name, fmt::format("expected a string, got {}", v.dump()));
    return v.get<std::string>();
  }
  // An optional string field, `otherwise` when absent or null.
  std::string text_or(const std::string& name, const std::string& otherwise) const {
    if (!j.contains(name) || j.at(name).is_null()) return otherwise;
    return text(name);
  }
};

constexpr std::size_t kMinRank = 2, kMaxRank = 5;

std::vector<std::int64_t> positive_list(const json& v, const std::string& file, const std::string& field,
                                        std::size_t rank) {
  if (!v.is_array() || v.size() < kMinRank || v.size() > kMaxRank || (rank && v.size() != rank))
    throw FormatError(file, field,
                      rank ? fmt::format("expected {} integers, got {}", rank, v.dump())
                           : fmt::format("expected {} to {} integers (z, y, x and up to two leading axes), got {}",
                                         kMinRank, kMaxRank, v.dump()));
  std::vector<std::int64_t> out;
  for (const json& n : v) {
    if (!n.is_number_integer() || n.get<std::int64_t>() < 1)
      throw FormatError(file, field, fmt::format("expected positive integers, got {}", v.dump()));
    out.push_back(n.get<std::int64_t>());
  }
  return out;
}

struct TypeName {
  std::string_view v2, v3;  // numpy kind+size, v3 data_type
  DType dtype;
};
constexpr TypeName kTypes[] = {{"u1", "uint8", DType::u8},     {"i1", "int8", DType::i8},
                               {"u2", "uint16", DType::u16},   {"i2", "int16", DType::i16},
                               {"u4", "uint32", DType::u32},   {"i4", "int32", DType::i32},
                               {"u8", "uint64", DType::u64},   {"i8", "int64", DType::i64},
                               {"f4", "float32", DType::f32},  {"f8", "float64", DType::f64}};

// "<u2" -> u16, little-endian; "|u1": no byte order.
void parse_v2_dtype(const std::string& text, ZarrArray& a) {
  const auto type = std::find_if(std::begin(kTypes), std::end(kTypes),
                                 [&](const TypeName& t) { return text.size() == 3 && text.substr(1) == t.v2; });
  if (type == std::end(kTypes) || (text[0] != '<' && text[0] != '>' && text[0] != '|'))
    throw FormatError(a.metadata_file, "dtype",
                      fmt::format("\"{}\" is not read (expected one of <u1 |i1 <u2 <i2 <u4 <i4 <u8 <i8 <f4 <f8, "
                                  "either byte order)",
                                  text));
  a.dtype = type->dtype;
  a.big_endian = text[0] == '>' && dtype_size(a.dtype) > 1;
}

DType parse_v3_dtype(const std::string& text, const std::string& file) {
  for (const TypeName& t : kTypes)
    if (text == t.v3) return t.dtype;
  throw FormatError(file, "data_type", fmt::format("\"{}\" is not read (expected uint8 ... int64, float32, float64)", text));
}

// One sample of `dtype` holding `value`, native order.
template <class T>
std::vector<std::byte> sample_bytes(T value) {
  std::vector<std::byte> out(sizeof(T));
  std::memcpy(out.data(), &value, sizeof(T));
  return out;
}

std::vector<std::byte> parse_fill(const json& v, DType dtype, const std::string& file) {
  const std::string field = "fill_value";
  return visit_dtype(dtype, [&](auto tag) -> std::vector<std::byte> {
    using T = decltype(tag);
    if (v.is_null()) return sample_bytes(T{});
    if constexpr (std::is_floating_point_v<T>) {
      if (v.is_number()) return sample_bytes(T(v.get<double>()));
      if (v.is_string()) {
        const std::string s = v.get<std::string>();
        if (s == "NaN") return sample_bytes(std::numeric_limits<T>::quiet_NaN());
        if (s == "Infinity") return sample_bytes(std::numeric_limits<T>::infinity());
        if (s == "-Infinity") return sample_bytes(-std::numeric_limits<T>::infinity());
        if (s.starts_with("0x") && s.size() == 2 + 2 * sizeof(T)) {  // v3: the float's bits in hex
          using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
          try {
            return sample_bytes(std::bit_cast<T>(Bits(std::stoull(s.substr(2), nullptr, 16))));
          } catch (const std::exception&) {
          }
        }
      }
    } else {
      if (v.is_boolean()) return sample_bytes(T(v.get<bool>()));
      if (v.is_number_unsigned() && v.get<std::uint64_t>() <= std::uint64_t(std::numeric_limits<T>::max()))
        return sample_bytes(T(v.get<std::uint64_t>()));
      if (v.is_number_integer() && !v.is_number_unsigned()) {
        const auto n = v.get<std::int64_t>();
        if (std::is_signed_v<T> ? n >= std::int64_t(std::numeric_limits<T>::min()) : n >= 0) return sample_bytes(T(n));
      }
      if (v.is_number_float()) {
        const double d = v.get<double>();
        if (std::trunc(d) == d && d >= double(std::numeric_limits<T>::min()) && d <= double(std::numeric_limits<T>::max()))
          return sample_bytes(T(d));
      }
    }
    throw FormatError(file, field, fmt::format("{} is not a {} value", v.dump(), dtype_name(dtype)));
  });
}

// Shape and chunk products must fit: the volume's bytes in 63 bits, a chunk's in kMaxZarrChunkBytes.
void check_sizes(const ZarrArray& a) {
  std::optional<std::uint64_t> total = dtype_size(a.dtype), chunk = dtype_size(a.dtype);
  for (std::size_t i = 0; i < a.shape.size(); ++i) {
    if (total) total = checked_mul(*total, std::uint64_t(a.shape[i]));
    if (chunk) chunk = checked_mul(*chunk, std::uint64_t(a.chunks[i]));
  }
  if (!total || *total > std::uint64_t(std::numeric_limits<std::int64_t>::max()))
    throw FormatError(a.metadata_file, "shape", "the array's byte count overflows 64 bits");
  if (!chunk || *chunk > kMaxZarrChunkBytes)
    throw FormatError(a.metadata_file, "chunks",
                      fmt::format("a chunk of more than {} bytes is not read", kMaxZarrChunkBytes));
}

std::vector<int> identity_axes(std::size_t rank) {
  std::vector<int> axes(rank);
  std::iota(axes.begin(), axes.end(), 0);
  return axes;
}

ZarrByteCodec v2_compressor(const json& c, const std::string& file) {
  if (!c.is_object() || !c.contains("id") || !c["id"].is_string())
    throw FormatError(file, "compressor", fmt::format("expected null or an object with an \"id\", got {}", c.dump()));
  const std::string id = c["id"].get<std::string>();
  if (id == "gzip" || id == "zlib") return ZarrByteCodec::gzip_or_zlib;
  if (id == "zstd") return ZarrByteCodec::zstd;
  if (id == "blosc") return ZarrByteCodec::blosc;
  throw FormatError(file, "compressor", fmt::format("\"{}\" is not read (expected gzip, zlib, zstd or blosc)", id));
}

ZarrArray parse_v2(const json& j, const std::string& file) {
  const Fields f{j, file};
  ZarrArray a;
  a.metadata_file = file;
  if (f.at("zarr_format") != 2) throw FormatError(file, "zarr_format", "expected 2");
  a.shape = positive_list(f.at("shape"), file, "shape", 0);
  a.chunks = positive_list(f.at("chunks"), file, "chunks", a.shape.size());
  parse_v2_dtype(f.text("dtype"), a);
  const std::string order = f.text_or("order", "C");
  if (order != "C" && order != "F") throw FormatError(file, "order", fmt::format("\"{}\" (expected C or F)", order));
  a.stored_axis = identity_axes(a.shape.size());
  if (order == "F") std::reverse(a.stored_axis.begin(), a.stored_axis.end());
  if (j.contains("compressor") && !j["compressor"].is_null()) a.byte_codecs.push_back(v2_compressor(j["compressor"], file));
  if (j.contains("filters") && !j["filters"].is_null() && !(j["filters"].is_array() && j["filters"].empty()))
    throw FormatError(file, "filters", fmt::format("{} is not read (expected null)", j["filters"].dump()));
  a.fill = parse_fill(j.contains("fill_value") ? j["fill_value"] : json(), a.dtype, file);
  const std::string separator = f.text_or("dimension_separator", ".");
  if (separator != "." && separator != "/")
    throw FormatError(file, "dimension_separator", fmt::format("\"{}\" (expected \".\" or \"/\")", separator));
  a.separator = separator[0];
  return a;
}

// v3 codec "configuration" (an object, empty when absent).
json configuration(const json& codec) { return codec.contains("configuration") ? codec["configuration"] : json::object(); }

// The "name" of a v3 codec object.
std::string codec_name(const json& codec, const std::string& file, const std::string& field) {
  if (codec.is_object() && codec.contains("name") && codec["name"].is_string()) return codec["name"].get<std::string>();
  throw FormatError(file, field, fmt::format("{} has no name", codec.dump()));
}

void parse_sharding(const json& config, ZarrArray& a, const std::string& field);

// `field`: where the list is ("codecs", or the inner codecs of sharding_indexed).
void parse_v3_codecs(const json& codecs, ZarrArray& a, const std::string& field = "codecs") {
  const std::string& file = a.metadata_file;
  if (!codecs.is_array() || codecs.empty()) throw FormatError(file, field, "expected a list of codecs");
  bool have_bytes = false;
  for (const json& codec : codecs) {
    const std::string name = codec_name(codec, file, field);
    const json config = configuration(codec);
    if (name == "sharding_indexed") {
      // Shards are read by range: nothing may transform a whole shard before or after it.
      if (field != "codecs")
        throw FormatError(file, field, "nested sharding_indexed is not read");
      if (codecs.size() != 1)
        throw FormatError(file, field, "sharding_indexed with other codecs around it is not read (expected it alone)");
      parse_sharding(config, a, field + ".sharding_indexed");
      return;
    }
    if (name == "transpose") {
      const json order = config.contains("order") ? config["order"] : json();
      std::vector<int> next;
      if (order.is_array() && order.size() == a.shape.size())
        for (const json& o : order)
          if (o.is_number_integer() && o.get<std::int64_t>() >= 0 && o.get<std::int64_t>() < std::int64_t(a.shape.size()))
            next.push_back(a.stored_axis[std::size_t(o.get<std::int64_t>())]);
      std::vector<int> sorted = next;
      std::sort(sorted.begin(), sorted.end());
      if (have_bytes || sorted != identity_axes(a.shape.size()))
        throw FormatError(file, field + ".transpose.order",
                          fmt::format("{} is not a permutation of the {} axes before the bytes codec", order.dump(),
                                      a.shape.size()));
      a.stored_axis = next;
    } else if (name == "bytes") {
      const std::string endian = config.contains("endian") && config["endian"].is_string() ? config["endian"].get<std::string>() : "little";
      if (endian != "little" && endian != "big")
        throw FormatError(file, field + ".bytes.endian", fmt::format("\"{}\" (expected little or big)", endian));
      a.big_endian = endian == "big" && dtype_size(a.dtype) > 1;
      have_bytes = true;
    } else if (name == "gzip" || name == "zstd" || name == "blosc" || name == "crc32c") {
      if (!have_bytes) throw FormatError(file, field, fmt::format("{} comes before the bytes codec", name));
      a.byte_codecs.push_back(name == "gzip"   ? ZarrByteCodec::gzip_or_zlib
                              : name == "zstd" ? ZarrByteCodec::zstd
                              : name == "blosc" ? ZarrByteCodec::blosc
                                                : ZarrByteCodec::crc32c);
    } else {
      throw FormatError(file, field,
                        fmt::format("codec \"{}\" is not read (expected transpose, bytes, gzip, zstd, blosc, crc32c, "
                                    "sharding_indexed)",
                                    name));
    }
  }
  if (!have_bytes) throw FormatError(file, field, "no bytes codec");
}

// index_codecs: bytes, optionally crc32c after it; what the index of every shard is encoded with.
void parse_index_codecs(const json& codecs, ZarrSharding& s, const std::string& file, const std::string& field) {
  std::vector<std::string> names;
  if (codecs.is_array())
    for (const json& c : codecs) names.push_back(codec_name(c, file, field));
  if (names.empty() || names[0] != "bytes" || names.size() > 2 || (names.size() == 2 && names[1] != "crc32c"))
    throw FormatError(file, field, fmt::format("{} is not read (expected bytes, then crc32c or nothing)", codecs.dump()));
  const json bytes_config = configuration(codecs[0]);
  const std::string endian = bytes_config.value("endian", json("little")).is_string()
                                 ? bytes_config.value("endian", std::string("little"))
                                 : std::string();
  if (endian != "little" && endian != "big")
    throw FormatError(file, field + ".bytes.endian", fmt::format("{} (expected little or big)", bytes_config.dump()));
  s.index_big_endian = endian == "big";
  s.index_crc32c = names.size() == 2;
}

// sharding_indexed's configuration: the inner chunks become the array's `chunks`.
void parse_sharding(const json& config, ZarrArray& a, const std::string& field) {
  const std::string& file = a.metadata_file;
  const Fields f{config, file};
  ZarrSharding s;
  s.shard_shape = a.chunks;
  const std::vector<std::int64_t> inner = positive_list(f.at("chunk_shape"), file, field + ".chunk_shape", a.shape.size());
  std::uint64_t entries = 1;
  for (std::size_t i = 0; i < inner.size(); ++i) {
    if (s.shard_shape[i] % inner[i] != 0)
      throw FormatError(file, field + ".chunk_shape",
                        fmt::format("{} does not divide the shard shape {}", config["chunk_shape"].dump(),
                                    json(s.shard_shape).dump()));
    s.per_shard.push_back(s.shard_shape[i] / inner[i]);
    const auto product = checked_mul(entries, std::uint64_t(s.per_shard.back()));
    if (!product || *product > kMaxZarrShardIndexEntries)
      throw FormatError(file, field + ".chunk_shape",
                        fmt::format("more than {} inner chunks per shard are not read", kMaxZarrShardIndexEntries));
    entries = *product;
  }
  const std::string location = f.text_or("index_location", "end");
  if (location != "end" && location != "start")
    throw FormatError(file, field + ".index_location", fmt::format("\"{}\" (expected end or start)", location));
  s.index_at_start = location == "start";
  parse_index_codecs(f.at("index_codecs"), s, file, field + ".index_codecs");
  a.chunks = inner;
  a.sharding = std::move(s);
  parse_v3_codecs(f.at("codecs"), a, field + ".codecs");
}

void parse_v3_key_encoding(const json& j, ZarrArray& a) {
  const std::string& file = a.metadata_file;
  std::string name = "default", separator;
  if (j.contains("chunk_key_encoding")) {
    const json& e = j["chunk_key_encoding"];
    const Fields f{e, file};
    name = f.text("name");
    const json config = configuration(e);
    if (config.contains("separator")) {
      if (!config["separator"].is_string()) throw FormatError(file, "chunk_key_encoding.separator", "expected a string");
      separator = config["separator"].get<std::string>();
    }
  }
  if (name != "default" && name != "v2")
    throw FormatError(file, "chunk_key_encoding", fmt::format("\"{}\" (expected default or v2)", name));
  if (separator.empty()) separator = name == "default" ? "/" : ".";
  if (separator != "." && separator != "/")
    throw FormatError(file, "chunk_key_encoding.separator", fmt::format("\"{}\" (expected \".\" or \"/\")", separator));
  a.separator = separator[0];
  a.key_prefix = name == "default" ? "c" + separator : "";
}

ZarrArray parse_v3(const json& j, const std::string& file) {
  const Fields f{j, file};
  ZarrArray a;
  a.metadata_file = file;
  a.zarr_format = 3;
  if (f.text("node_type") != "array") throw FormatError(file, "node_type", "a group, not an array");
  a.shape = positive_list(f.at("shape"), file, "shape", 0);
  a.dtype = parse_v3_dtype(f.text("data_type"), file);
  const json& grid = f.at("chunk_grid");
  if (Fields{grid, file}.text("name") != "regular")
    throw FormatError(file, "chunk_grid.name", fmt::format("{} (expected regular)", grid["name"].dump()));
  a.chunks = positive_list(Fields{configuration(grid), file}.at("chunk_shape"), file, "chunk_grid.chunk_shape",
                           a.shape.size());
  if (j.contains("storage_transformers") && !(j["storage_transformers"].is_array() && j["storage_transformers"].empty()))
    throw FormatError(file, "storage_transformers", "not read");
  a.stored_axis = identity_axes(a.shape.size());
  parse_v3_codecs(f.at("codecs"), a);
  parse_v3_key_encoding(j, a);
  a.fill = parse_fill(f.at("fill_value"), a.dtype, file);
  return a;
}

}  // namespace

std::uint32_t crc32c(std::span<const std::byte> data) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? (c >> 1) ^ 0x82F63B78u : c >> 1;  // Castagnoli, reflected
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t crc = ~0u;
  for (std::byte b : data) crc = table[(crc ^ std::to_integer<std::uint32_t>(b)) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

namespace {

// Undoes one bytes-to-bytes codec; `limit` bounds what it may decode to.
std::vector<std::byte> undo(ZarrByteCodec codec, const std::vector<std::byte>& in, std::uint64_t limit,
                            const std::string& file, const std::string& chunk) {
  switch (codec) {
    case ZarrByteCodec::gzip_or_zlib:
      return gunzip_to_memory(in.data(), in.size(), file, chunk, limit + 1, /*accept_zlib=*/true);
    case ZarrByteCodec::zstd: {
      const unsigned long long declared = ZSTD_getFrameContentSize(in.data(), in.size());
      if (declared == ZSTD_CONTENTSIZE_ERROR) throw FormatError(file, chunk, "not a zstd frame");
      const std::uint64_t capacity = declared == ZSTD_CONTENTSIZE_UNKNOWN ? limit : std::min<std::uint64_t>(declared, limit + 1);
      std::vector<std::byte> out(capacity);
      const std::size_t n = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
      // Strata's words, not zstd's ("Data corruption detected").
      if (ZSTD_isError(n) && ZSTD_getErrorCode(n) == ZSTD_error_dstSize_tooSmall)
        throw FormatError(file, chunk, fmt::format("zstd data that decodes to more than the {} bytes of a chunk", limit));
      if (ZSTD_isError(n)) throw FormatError(file, chunk, "damaged zstd data: expected a zstd frame that decodes");
      out.resize(n);
      return out;
    }
    case ZarrByteCodec::blosc: {
      std::size_t declared = 0;
      if (blosc_cbuffer_validate(in.data(), in.size(), &declared) < 0)
        throw FormatError(file, chunk, "not a blosc buffer (or a truncated one)");
      if (declared > limit) throw FormatError(file, chunk, fmt::format("blosc declares {} bytes, more than {}", declared, limit));
      std::vector<std::byte> out(declared);
      if (declared > 0 && blosc_decompress_ctx(in.data(), out.data(), out.size(), 1) != int(declared))
        throw FormatError(file, chunk, "blosc cannot decode it (damaged, or an inner codec this libblosc lacks)");
      return out;
    }
    case ZarrByteCodec::crc32c: {
      if (in.size() < 4) throw FormatError(file, chunk, "shorter than its crc32c checksum");
      const std::span<const std::byte> body(in.data(), in.size() - 4);
      if (load_field<std::uint32_t>(std::span<const std::byte>(in), in.size() - 4) != crc32c(body))
        throw FormatError(file, chunk, "crc32c checksum mismatch (a damaged chunk)");
      return {body.begin(), body.end()};
    }
  }
  throw FormatError(file, chunk, "unknown codec");
}

}  // namespace

std::uint64_t ZarrArray::chunk_bytes() const {
  std::uint64_t n = dtype_size(dtype);
  for (std::int64_t c : chunks) n *= std::uint64_t(c);  // checked by parse_zarr_array
  return n;
}

std::uint64_t ZarrSharding::index_entries() const {
  std::uint64_t n = 1;
  for (std::int64_t c : per_shard) n *= std::uint64_t(c);  // checked by parse_sharding
  return n;
}

std::uint64_t ZarrSharding::index_bytes() const { return 16 * index_entries() + (index_crc32c ? 4 : 0); }

std::string ZarrArray::chunk_key(std::span<const std::int64_t> index) const {
  std::string key = key_prefix;
  for (std::size_t i = 0; i < index.size(); ++i) {
    if (i) key += separator;
    key += std::to_string(index[i]);
  }
  return join_key(node, key);
}

json read_zarr_json(const ZarrStore& store, const std::string& key) {
  const std::string file = store.name(key);
  const std::optional<std::uint64_t> size = store.size(key);
  if (!size) throw FormatError(file, "metadata", "cannot read: missing");
  if (*size > kMaxZarrMetadataBytes)
    throw FormatError(file, "metadata", fmt::format("{} bytes of JSON, more than the {} read", *size, kMaxZarrMetadataBytes));
  const std::vector<std::byte> bytes = store.read(key, 0, *size, "metadata");
  const std::string text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (json_depth(text, kMaxZarrJsonDepth) > kMaxZarrJsonDepth)
    throw FormatError(file, "metadata", fmt::format("JSON nested deeper than {} levels", kMaxZarrJsonDepth));
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) throw FormatError(file, "metadata", "not valid JSON");
  if (!j.is_object()) throw FormatError(file, "metadata", "expected a JSON object");
  return j;
}

ZarrArray parse_zarr_array(std::shared_ptr<const ZarrStore> store, const std::string& node) {
  const std::string v2 = join_key(node, ".zarray"), v3 = join_key(node, "zarr.json");
  const bool is_v2 = store->exists(v2);
  const std::string key = is_v2 ? v2 : v3;
  const json j = read_zarr_json(*store, key);
  ZarrArray a = is_v2 ? parse_v2(j, store->name(key)) : parse_v3(j, store->name(key));
  a.store = std::move(store);
  a.node = node;
  check_sizes(a);
  return a;
}

std::vector<std::byte> decode_zarr_chunk(const ZarrArray& array, std::vector<std::byte> encoded,
                                         const std::string& chunk_name) {
  const std::uint64_t expected = array.chunk_bytes();
  // Codecs before the last one decode to at most the largest chunk read; the last to the chunk.
  for (std::size_t i = array.byte_codecs.size(); i-- > 0;)
    encoded = undo(array.byte_codecs[i], encoded, i == 0 ? expected : kMaxZarrChunkBytes, chunk_name, "chunk");
  if (encoded.size() != expected)
    throw FormatError(chunk_name, "chunk",
                      fmt::format("decodes to {} bytes, a chunk of {} holds {}", encoded.size(),
                                  dtype_name(array.dtype), expected));
  if (array.big_endian) byte_swap(encoded.data(), encoded.size() / dtype_size(array.dtype), dtype_size(array.dtype));
  return encoded;
}

std::vector<std::byte> blosc_zstd_compress(std::span<const std::byte> chunk, std::size_t sample_size) {
  std::vector<std::byte> out(chunk.size() + BLOSC_MAX_OVERHEAD);
  const int n = blosc_compress_ctx(5, BLOSC_SHUFFLE, sample_size, chunk.size(), chunk.data(), out.data(), out.size(),
                                   "zstd", 0, 1);
  if (n <= 0) throw Error("blosc (zstd) compression failed");
  out.resize(std::size_t(n));
  return out;
}

json blosc_zstd_compressor_json() {
  return {{"id", "blosc"}, {"cname", "zstd"}, {"clevel", 5}, {"shuffle", 1}, {"blocksize", 0}};
}

std::string zarr_v2_dtype(DType dtype) {
  for (const TypeName& t : kTypes)
    if (t.dtype == dtype) return std::string(dtype_size(dtype) == 1 ? "|" : "<") + std::string(t.v2);
  throw Error("zarr: no numpy type for " + std::string(dtype_name(dtype)));
}

}  // namespace strata::io::detail
