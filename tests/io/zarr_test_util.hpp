#pragma once
// Shared by the Zarr tests: the refusal check, deflate, and Zarr v3 sharded arrays written as the
// sharding_indexed codec specifies (zarr-specs v3, codecs/sharding-indexed). zarr-python 2 cannot
// write them, so the tests build the shards themselves from a u16 volume, byte for byte: inner chunks of chunk_shape (edge chunks padded
// with the fill value), bytes little-endian then gzip, in reverse order in the shard; the index
// (u64 offset, u64 nbytes per inner chunk in C order, 2^64-1 both for an empty one) at the end or
// the start, optionally followed by its crc32c.
#include <zlib.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/io_test_util.hpp"
#include "io/zarr/zarr_array.hpp"
#include "strata/core/volume.hpp"
#include "support/test_support.hpp"

namespace strata::test::zarr {

using Cell = std::array<std::int64_t, 3>;  // z, y, x

struct ShardOptions {
  Cell shard{4, 8, 8}, inner{2, 4, 4};
  bool index_at_start = false, crc32c = false, big_endian_index = false;
  std::uint16_t fill = 7;
  std::set<Cell> missing_shards;      // shard grid cells not written
  std::set<Cell> empty_inner;         // inner grid cells (of the whole array) marked empty
};

// Writes a file, making its folders.
inline void put_file(const std::filesystem::path& path, const std::vector<std::byte>& bytes) {
  std::filesystem::create_directories(path.parent_path());
  io::write_bytes(path, bytes);
}

inline std::vector<std::byte> text_bytes(const std::string& text) {
  std::vector<std::byte> out(text.size());
  std::memcpy(out.data(), text.data(), text.size());
  return out;
}

// `f` throws an error whose message names `file_part` and `field`.
inline void expect_refused(const std::function<void()>& f, const std::string& file_part, const std::string& field) {
  const std::string message = error_of(f);
  EXPECT_NE(message.find(file_part), std::string::npos) << message;
  EXPECT_NE(message.find(field), std::string::npos) << message;
}

// Deflate-compressed `in`: window_bits 15 + 16 a gzip stream, -15 raw deflate (zip members).
inline std::vector<std::byte> deflate_bytes(const std::vector<std::byte>& in, int window_bits) {
  z_stream s{};
  deflateInit2(&s, 6, Z_DEFLATED, window_bits, 8, Z_DEFAULT_STRATEGY);
  std::vector<std::byte> out(deflateBound(&s, uLong(in.size())) + 32);
  s.next_in = reinterpret_cast<Bytef*>(const_cast<std::byte*>(in.data()));
  s.avail_in = uInt(in.size());
  s.next_out = reinterpret_cast<Bytef*>(out.data());
  s.avail_out = uInt(out.size());
  deflate(&s, Z_FINISH);
  out.resize(s.total_out);
  deflateEnd(&s);
  return out;
}

inline void put_u64(std::vector<std::byte>& out, std::uint64_t v, bool big_endian) {
  for (int i = 0; i < 8; ++i) out.push_back(std::byte((v >> (8 * (big_endian ? 7 - i : i))) & 0xFF));
}

inline nlohmann::json sharded_metadata(const Extent& dims, const ShardOptions& o) {
  using nlohmann::json;
  json index_codecs = json::array({{{"name", "bytes"}, {"configuration", {{"endian", o.big_endian_index ? "big" : "little"}}}}});
  if (o.crc32c) index_codecs.push_back({{"name", "crc32c"}});
  const json sharding = {{"name", "sharding_indexed"},
                         {"configuration",
                          {{"chunk_shape", o.inner},
                           {"codecs", json::array({{{"name", "bytes"}, {"configuration", {{"endian", "little"}}}},
                                                   {{"name", "gzip"}, {"configuration", {{"level", 5}}}}})},
                           {"index_codecs", index_codecs},
                           {"index_location", o.index_at_start ? "start" : "end"}}}};
  return {{"zarr_format", 3},
          {"node_type", "array"},
          {"shape", {dims.z, dims.y, dims.x}},
          {"data_type", "uint16"},
          {"chunk_grid", {{"name", "regular"}, {"configuration", {{"chunk_shape", o.shard}}}}},
          {"chunk_key_encoding", {{"name", "default"}}},
          {"fill_value", o.fill},
          {"codecs", json::array({sharding})},
          {"attributes", json::object()}};
}

// The encoded inner chunk at inner grid cell `c` of `v` (u16).
inline std::vector<std::byte> inner_chunk(const Volume& v, const Cell& c, const ShardOptions& o) {
  const Extent d = v.dims();
  std::vector<std::uint16_t> samples;
  for (std::int64_t z = c[0] * o.inner[0]; z < (c[0] + 1) * o.inner[0]; ++z)
    for (std::int64_t y = c[1] * o.inner[1]; y < (c[1] + 1) * o.inner[1]; ++y)
      for (std::int64_t x = c[2] * o.inner[2]; x < (c[2] + 1) * o.inner[2]; ++x)
        samples.push_back(z < d.z && y < d.y && x < d.x ? v.samples<std::uint16_t>()[std::size_t((z * d.y + y) * d.x + x)]
                                                        : o.fill);
  std::vector<std::byte> bytes(samples.size() * 2);
  std::memcpy(bytes.data(), samples.data(), bytes.size());
  return deflate_bytes(bytes, 15 + 16);
}

// The bytes of shard `s`: inner chunks (reverse order), index at the end or start.
inline std::vector<std::byte> shard_bytes(const Volume& v, const Cell& s, const ShardOptions& o) {
  Cell per;
  for (int a = 0; a < 3; ++a) per[std::size_t(a)] = o.shard[std::size_t(a)] / o.inner[std::size_t(a)];
  const std::size_t n = std::size_t(per[0] * per[1] * per[2]);
  const std::uint64_t index_size = 16 * n + (o.crc32c ? 4 : 0);
  std::vector<std::pair<std::uint64_t, std::uint64_t>> entries(n, {~0ull, ~0ull});
  std::vector<std::byte> data;
  const std::uint64_t base = o.index_at_start ? index_size : 0;
  for (std::size_t k = n; k-- > 0;) {
    const Cell local{std::int64_t(k) / (per[1] * per[2]), std::int64_t(k) / per[2] % per[1], std::int64_t(k) % per[2]};
    const Cell c{s[0] * per[0] + local[0], s[1] * per[1] + local[1], s[2] * per[2] + local[2]};
    if (o.empty_inner.count(c)) continue;
    const std::vector<std::byte> chunk = inner_chunk(v, c, o);
    entries[k] = {base + data.size(), chunk.size()};
    data.insert(data.end(), chunk.begin(), chunk.end());
  }
  std::vector<std::byte> index;
  for (const auto& [offset, nbytes] : entries) {
    put_u64(index, offset, o.big_endian_index);
    put_u64(index, nbytes, o.big_endian_index);
  }
  if (o.crc32c) {
    const std::uint32_t crc = strata::io::detail::crc32c(index);
    for (int i = 0; i < 4; ++i) index.push_back(std::byte((crc >> (8 * i)) & 0xFF));
  }
  std::vector<std::byte> out = o.index_at_start ? index : data;
  const std::vector<std::byte>& rest = o.index_at_start ? data : index;
  out.insert(out.end(), rest.begin(), rest.end());
  return out;
}

// Writes `v` (u16) as a sharded v3 array in the folder `store`; returns what reading it must
// give: `v` with the missing shards and empty inner chunks at the fill value.
inline Volume write_sharded(const std::filesystem::path& store, const Volume& v, const ShardOptions& o) {
  const Extent d = v.dims();
  put_file(store / "zarr.json", text_bytes(sharded_metadata(d, o).dump()));
  Volume expected = v;
  auto* out = expected.samples<std::uint16_t>().data();
  const Cell shards{(d.z + o.shard[0] - 1) / o.shard[0], (d.y + o.shard[1] - 1) / o.shard[1], (d.x + o.shard[2] - 1) / o.shard[2]};
  for (std::int64_t i = 0; i < shards[0]; ++i)
    for (std::int64_t j = 0; j < shards[1]; ++j)
      for (std::int64_t k = 0; k < shards[2]; ++k)
        if (!o.missing_shards.count({i, j, k}))
          put_file(store / fmt::format("c/{}/{}/{}", i, j, k), shard_bytes(v, {i, j, k}, o));
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const Cell shard{z / o.shard[0], y / o.shard[1], x / o.shard[2]}, inner{z / o.inner[0], y / o.inner[1], x / o.inner[2]};
        if (o.missing_shards.count(shard) || o.empty_inner.count(inner)) out[std::size_t((z * d.y + y) * d.x + x)] = o.fill;
      }
  return expected;
}

}  // namespace strata::test::zarr
