#pragma once
// One Zarr array (v2 `.zarray` or v3 `zarr.json`): its metadata parsed into ZarrArray, the key
// of each chunk, and the decoding of a chunk's bytes into native-order samples. Private to io;
// the format entry (src/io/zarr.cpp) builds the volume source on it.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/zarr/zarr_store.hpp"
#include "strata/core/dtype.hpp"

namespace strata::io::detail {

// Metadata documents larger than this are refused before parsing (a real one is a few KB).
inline constexpr std::uintmax_t kMaxZarrMetadataBytes = 16u << 20;
// JSON nested deeper than this is refused before parsing (real metadata nests 4 or 5 levels).
inline constexpr int kMaxZarrJsonDepth = 64;
// A decoded chunk larger than this is refused before anything is allocated for it (zarr's
// default chunks hold about 1 MiB; the largest in use, a few hundred).
inline constexpr std::uint64_t kMaxZarrChunkBytes = std::uint64_t(512) << 20;

// A shard index larger than this is refused when the metadata is read (a real one: 4096 inner
// chunks of 64^3 in a 1024^3 shard, 64 KiB).
inline constexpr std::uint64_t kMaxZarrShardIndexEntries = 1u << 20;

// The bytes-to-bytes steps of a chunk (v2 `compressor`, v3 bytes-to-bytes codecs).
enum class ZarrByteCodec : std::uint8_t { gzip_or_zlib, zstd, blosc, crc32c };

// v3 `sharding_indexed` (src/io/zarr/zarr_chunk_reader.cpp reads the shards): the chunk grid's cells
// are shards, one key each, holding `per_shard` inner chunks and an index of where each is.
struct ZarrSharding {
  std::vector<std::int64_t> shard_shape;  // chunk_grid.chunk_shape
  std::vector<std::int64_t> per_shard;    // inner chunks per shard along each axis
  bool index_at_start = false;            // index_location "start" (default "end")
  bool index_crc32c = false;              // index_codecs end with crc32c
  bool index_big_endian = false;          // index_codecs' bytes endian
  std::uint64_t index_entries() const;    // inner chunks per shard (checked at parse time)
  std::uint64_t index_bytes() const;      // 16 per inner chunk, + 4 with crc32c
};

struct ZarrArray {
  std::shared_ptr<const ZarrStore> store;
  std::string node;           // the array's key in the store ("" for the root)
  std::string metadata_file;  // ".zarray" or "zarr.json" as messages name it
  int zarr_format = 2;
  // C order: the last axis is x. `chunks` is what one decodes: the inner chunks when sharded.
  std::vector<std::int64_t> shape, chunks;
  DType dtype = DType::u8;
  bool big_endian = false;
  // stored_axis[k]: the logical axis that is the k-th (slowest first) of a stored chunk: identity
  // for C order, reversed for F order, v3 `transpose` order otherwise.
  std::vector<int> stored_axis;
  // In the order they were applied when writing; decoding undoes them last to first. crc32c:
  // the last 4 bytes are the checksum of the bytes before them.
  std::vector<ZarrByteCodec> byte_codecs;
  std::vector<std::byte> fill;  // one sample in native order
  // Chunk keys: v2 "i.j.k" (or "i/j/k"), v3 default "c/i/j/k".
  std::string key_prefix;  // "" or "c" + separator
  char separator = '.';
  std::optional<ZarrSharding> sharding;

  std::uint64_t chunk_bytes() const;  // decoded size of a whole chunk
  // The key of a cell of the chunk grid (a shard when sharded).
  std::string chunk_key(std::span<const std::int64_t> index) const;
};

// Reads and parses a metadata JSON value of the store, refusing huge or deeply nested ones, with
// FormatError naming it.
nlohmann::json read_zarr_json(const ZarrStore& store, const std::string& key);

// Parses `.zarray` (v2) or a `zarr.json` whose node_type is "array" (v3) of the node `node`.
// Throws FormatError(file, field, ...) for anything missing, malformed, not read, or whose
// shape or chunk sizes overflow.
ZarrArray parse_zarr_array(std::shared_ptr<const ZarrStore> store, const std::string& node);

// crc32c (Castagnoli) of `data`: v3's crc32c codec, also at the end of a shard index.
std::uint32_t crc32c(std::span<const std::byte> data);

// The decoded, native-order, stored-axis-order samples of a chunk from its file's bytes: decompressed,
// checksum checked, byte-swapped. FormatError(chunk_file, "chunk", ...) when it is damaged or
// decodes to the wrong size.
std::vector<std::byte> decode_zarr_chunk(const ZarrArray& array, std::vector<std::byte> encoded,
                                         const std::string& chunk_file);

// Compresses a chunk of `sample_size`-byte samples with blosc (zstd inside, byte shuffle), the
// compressor the OME-Zarr writer records as {"id": "blosc", "cname": "zstd", ...}.
std::vector<std::byte> blosc_zstd_compress(std::span<const std::byte> chunk, std::size_t sample_size);
// The `.zarray` "compressor" value blosc_zstd_compress writes.
nlohmann::json blosc_zstd_compressor_json();

// The numpy type string of a sample type, little-endian ("<u2", "|u1").
std::string zarr_v2_dtype(DType dtype);

}  // namespace strata::io::detail
