// Zarr v3 sharding_indexed: shards written here byte for byte as the spec says (index at the end
// or the start, with and without crc32c, either index byte order, gzip inner chunks, an empty
// inner chunk, a missing shard) read back equal to the source; a box decodes only the inner
// chunks it touches; damaged shards and metadata refused naming the file and field.
#include <gtest/gtest.h>

#include <functional>

#include "io/zarr_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::TempDir;
using test::zarr::expect_refused;
using test::zarr::ShardOptions;

// 14 x 12 x 10 (x, y, z): shards 8 x 8 x 4 leave partial shards on every axis.
Volume source() { return test::io::random_volume({14, 12, 10}, DType::u16, 11, {1, 1, 1}); }

TEST(IoZarrShard, EveryIndexLayoutReadsBackExactly) {
  TempDir dir;
  const Volume v = source();
  struct Layout {
    const char* name;
    bool start, crc, big;
  };
  for (const Layout& l : {Layout{"end", false, false, false}, Layout{"end-crc", false, true, false},
                          Layout{"start-crc", true, true, false}, Layout{"start", true, false, false},
                          Layout{"end-big", false, true, true}}) {
    ShardOptions o;
    o.index_at_start = l.start;
    o.crc32c = l.crc;
    o.big_endian_index = l.big;
    o.missing_shards = {{1, 0, 1}};
    o.empty_inner = {{0, 0, 0}, {4, 2, 3}};  // the first inner chunk, and one in the last shard
    const fs::path store = dir / (std::string(l.name) + ".zarr");
    const Volume expected = test::zarr::write_sharded(store, v, o);
    ASSERT_FALSE(fs::exists(store / "c/1/0/1"));
    auto opened = open_volume(store);
    test::io::expect_same(opened->read_all(), expected, l.name);
    const Box box{{3, 5, 1}, {13, 12, 9}};  // across shard borders on every axis
    EXPECT_TRUE(opened->read_box(box) == expected.crop(box)) << l.name;
    EXPECT_EQ(expected.samples<std::uint16_t>()[0], 7);  // the empty inner chunk is the fill value
  }
}

TEST(IoZarrShard, ABoxDecodesOnlyTheInnerChunksItTouches) {
  TempDir dir;
  const Volume v = source();
  const fs::path store = dir / "s.zarr";
  const Volume expected = test::zarr::write_sharded(store, v, {});
  // Damage inner chunk (0, 0, 0) of shard (0, 0, 0) where its index entry says it starts (the
  // index is at the end: 2 x 2 x 2 entries of 16 bytes, the first one this chunk's offset).
  std::vector<std::byte> shard = test::io::read_bytes(store / "c/0/0/0");
  const std::size_t index_at = shard.size() - 8 * 16;
  std::uint64_t offset = 0;
  std::memcpy(&offset, shard.data() + index_at, 8);
  shard[offset] = std::byte{0};  // no longer a gzip stream
  test::zarr::put_file(store / "c/0/0/0", shard);
  auto opened = open_volume(store);
  // x 4..8, y 4..8, z 2..4: inner chunk (1, 1, 1) of the same shard, not (0, 0, 0).
  const Box box{{4, 4, 2}, {8, 8, 4}};
  EXPECT_TRUE(opened->read_box(box) == expected.crop(box));
  expect_refused([&] { (void)opened->read_box(Box{{0, 0, 0}, {1, 1, 1}}); }, "c/0/0/0 (inner chunk 0)", "chunk");
}

// A one-shard array (4 x 4 x 2 of u16, inner 2 x 2 x 2: 4 inner chunks) whose shard is `shard`.
fs::path one_shard(const fs::path& dir, const std::string& name, const std::vector<std::byte>& shard, ShardOptions o = {}) {
  o.shard = {2, 4, 4};
  o.inner = {2, 2, 2};
  const fs::path store = dir / name;
  test::zarr::put_file(store / "zarr.json", test::zarr::text_bytes(test::zarr::sharded_metadata({4, 4, 2}, o).dump()));
  test::zarr::put_file(store / "c/0/0/0", shard);
  return store;
}

std::vector<std::byte> index_of(const std::vector<std::pair<std::uint64_t, std::uint64_t>>& entries) {
  std::vector<std::byte> out;
  for (const auto& [offset, nbytes] : entries) {
    test::zarr::put_u64(out, offset, false);
    test::zarr::put_u64(out, nbytes, false);
  }
  return out;
}

TEST(IoZarrShard, DamagedShardsAreRefusedNamingTheShardIndex) {
  TempDir dir;
  const auto read = [](const fs::path& p) { return [p] { (void)read_volume(p); }; };
  const std::uint64_t empty = ~0ull;
  const std::vector<std::pair<std::uint64_t, std::uint64_t>> all_empty(4, {empty, empty});
  // Every inner chunk empty: the fill value, nothing refused.
  const Volume fill = read_volume(one_shard(dir.path(), "empty.zarr", index_of(all_empty)));
  EXPECT_EQ(fill.samples<std::uint16_t>()[5], 7);
  // Entries outside the shard: past its end, and offset + nbytes wrapping around 2^64.
  auto outside = all_empty;
  outside[2] = {10, 1000};
  expect_refused(read(one_shard(dir.path(), "outside.zarr", index_of(outside))), "c/0/0/0", "shard index: inner chunk 2");
  outside[2] = {empty - 4, 64};
  expect_refused(read(one_shard(dir.path(), "wrap.zarr", index_of(outside))), "c/0/0/0", "shard index");
  outside[2] = {empty, 0};  // only one half empty
  expect_refused(read(one_shard(dir.path(), "half.zarr", index_of(outside))), "c/0/0/0", "shard index");
  // Shorter than its index (an index for fewer inner chunks than the metadata says).
  expect_refused(read(one_shard(dir.path(), "short.zarr", index_of({{empty, empty}}))), "c/0/0/0", "shard index");
  // A crc32c that does not match.
  ShardOptions crc;
  crc.crc32c = true;
  std::vector<std::byte> bad_crc = index_of(all_empty);
  bad_crc.insert(bad_crc.end(), {std::byte{1}, std::byte{2}, std::byte{3}, std::byte{4}});
  expect_refused(read(one_shard(dir.path(), "crc.zarr", bad_crc, crc)), "c/0/0/0", "shard index: crc32c");
  // An inner chunk of more bytes than an inner chunk of 16 bytes can encode to.
  std::vector<std::byte> big(2u << 20);
  const std::vector<std::byte> index = index_of({{0, big.size()}, {empty, empty}, {empty, empty}, {empty, empty}});
  big.insert(big.end(), index.begin(), index.end());
  expect_refused(read(one_shard(dir.path(), "big.zarr", big)), "c/0/0/0", "shard index");
}

json sharded(json configuration_patch, json outer_codecs_extra = json::array()) {
  ShardOptions o;
  json meta = test::zarr::sharded_metadata({14, 12, 10}, o);
  if (configuration_patch.is_object()) meta["codecs"][0]["configuration"].update(configuration_patch);
  for (const json& c : outer_codecs_extra) meta["codecs"].push_back(c);
  return meta;
}

TEST(IoZarrShard, UnreadShardingMetadataIsRefusedNamingCodecs) {
  TempDir dir;
  const auto refused = [&](const std::string& name, const json& meta, const std::string& field) {
    const fs::path store = dir / name;
    test::zarr::put_file(store / "zarr.json", test::zarr::text_bytes(meta.dump()));
    expect_refused([&] { (void)open_volume(store); }, "zarr.json", field);
  };
  refused("divide.zarr", sharded({{"chunk_shape", {3, 4, 4}}}), "codecs.sharding_indexed.chunk_shape");
  // 2^30 inner chunks of one sample in a 1024^3 shard: refused before any index is allocated.
  json huge = sharded({{"chunk_shape", {1, 1, 1}}});
  huge["chunk_grid"]["configuration"]["chunk_shape"] = {1024, 1024, 1024};
  refused("huge.zarr", huge, "codecs.sharding_indexed.chunk_shape");
  const json inner_sharding = sharded({}).at("codecs");
  refused("nested.zarr", sharded({{"codecs", inner_sharding}}), "codecs.sharding_indexed.codecs: nested");
  refused("around.zarr", sharded({}, json::array({{{"name", "crc32c"}}})), "codecs: sharding_indexed with other");
  refused("location.zarr", sharded({{"index_location", "middle"}}), "codecs.sharding_indexed.index_location");
  refused("index.zarr", sharded({{"index_codecs", json::array({{{"name", "gzip"}}})}}),
          "codecs.sharding_indexed.index_codecs");
  refused("noindex.zarr", sharded({{"index_codecs", nullptr}}), "codecs.sharding_indexed.index_codecs");
}

}  // namespace
}  // namespace strata::io
