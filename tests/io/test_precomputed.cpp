// Neuroglancer precomputed volumes: what the writer stores reads back exactly (raw images,
// compressed_segmentation labels of 32 and 64 bits, several scales), stores built here byte by
// byte (unsharded with a voxel offset, gzip and missing chunks; sharded with the identity hash)
// read as their layout says, the hash and chunk ids match the specification, and damaged stores
// are refused naming the file and field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/io_test_util.hpp"
#include "io/precomputed/compressed_segmentation.hpp"
#include "io/precomputed/sharding.hpp"
#include "strata/core/bytes.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/precomputed.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using namespace detail::precomputed;
using test::TempDir;
using test::io::expect_error;
using test::io::expect_same;
using test::io::random_volume;
using test::io::write_bytes;
using test::io::write_gzipped;
using test::io::write_text;

// Labels as segmentations have them: few distinct ids per region, offset by `base`.
Volume label_volume(Extent dims, DType dtype, std::uint64_t base, std::uint64_t seed) {
  Volume v(dims, dtype, Spacing{4, 4, 40});
  std::mt19937_64 rng(seed);
  visit_dtype(dtype, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (std::is_integral_v<T>) {
      auto s = v.view<T>();
      for (std::int64_t z = 0; z < dims.z; ++z)
        for (std::int64_t y = 0; y < dims.y; ++y)
          for (std::int64_t x = 0; x < dims.x; ++x)
            s(x, y, z) = T(base + (x / 5 + 7 * (y / 6) + 31 * (z / 4)) % 23 + (rng() % 16 == 0 ? rng() % 1000 : 0));
    }
  });
  return v;
}

Volume with_geometry(Volume v, Vector3 origin) {
  VolumeInfo info = v.info();
  info.geometry.unit = "nm";
  info.geometry.origin = origin;
  Volume out(info);
  std::memcpy(out.bytes(), v.bytes(), v.byte_size());
  return out;
}

nlohmann::json info_of(const fs::path& folder) {
  std::ifstream in(folder / "info");
  return nlohmann::json::parse(in);
}

TEST(IoPrecomputed, RawImagesOfEveryStoredTypeReadBackWithSpacingAndOrigin) {
  TempDir dir;
  for (DType dtype : {DType::u8, DType::i8, DType::u16, DType::i16, DType::i32, DType::f32}) {
    const fs::path path = dir / (std::string(dtype_name(dtype)) + ".precomputed");
    // 70 x 66 x 67: partial chunks at the upper edge of every axis.
    const Volume v = with_geometry(random_volume({70, 66, 67}, dtype, 7, Spacing{4, 8, 40}), {40, -16, 400});
    write_volume(path, v);
    const auto source = open_volume(path);
    EXPECT_EQ(source->info().spacing, (Spacing{4, 8, 40}));
    EXPECT_EQ(source->info().geometry.unit, "nm");
    EXPECT_EQ(source->info().geometry.origin, (Vector3{40, -16, 400}));
    expect_same(source->read_all(), v, std::string(dtype_name(dtype)));
    const Box box{{3, 60, 1}, {69, 66, 66}};
    EXPECT_TRUE(source->read_box(box) == v.crop(box)) << dtype_name(dtype);
    const auto info = info_of(path);
    EXPECT_EQ(info["type"], "image");
    EXPECT_EQ(info["scales"][0]["encoding"], "raw");
    EXPECT_EQ(info["scales"][0]["voxel_offset"], nlohmann::json({10, -2, 10}));
  }
}

TEST(IoPrecomputed, SpacingInOtherUnitsIsWrittenInNanometres) {
  TempDir dir;
  const fs::path path = dir / "um.precomputed";
  Volume v = random_volume({5, 4, 3}, DType::u8, 2, Spacing{0.5, 0.25, 2});
  VolumeInfo info = v.info();
  info.geometry.unit = "um";
  info.geometry.origin = {1.5, -0.5, 4};
  Volume placed(info);
  std::memcpy(placed.bytes(), v.bytes(), v.byte_size());
  write_volume(path, placed);
  const auto scale = info_of(path)["scales"][0];
  EXPECT_EQ(scale["resolution"], nlohmann::json({500.0, 250.0, 2000.0}));
  EXPECT_EQ(scale["voxel_offset"], nlohmann::json({3, -2, 2}));
  const auto source = open_volume(path);
  EXPECT_EQ(source->info().spacing, (Spacing{500, 250, 2000}));
  EXPECT_EQ(source->info().geometry.origin, (Vector3{1500, -500, 4000}));
}

TEST(IoPrecomputed, LabelsOf32And64BitsRoundTripThroughCompressedSegmentation) {
  TempDir dir;
  for (auto [dtype, base] :
       {std::pair{DType::u32, std::uint64_t(3'000'000'000)}, std::pair{DType::u64, std::uint64_t(1) << 41}}) {
    const fs::path path = dir / (std::string(dtype_name(dtype)) + ".precomputed");
    const Volume v = label_volume({70, 65, 66}, dtype, base, 3);
    write_volume(path, v);
    const auto info = info_of(path);
    EXPECT_EQ(info["type"], "segmentation");
    EXPECT_EQ(info["scales"][0]["encoding"], "compressed_segmentation");
    // The encoding is much smaller than the samples: the tables hold a few ids per block.
    std::uint64_t bytes = 0;
    for (const auto& f : fs::recursive_directory_iterator(path))
      if (f.is_regular_file()) bytes += f.file_size();
    EXPECT_LT(bytes, v.byte_size() / 2);
    expect_same(read_volume(path), v, std::string(dtype_name(dtype)));
  }
}

TEST(IoPrecomputed, CompressedSegmentationDecodesWhatItEncodesForOddBlocks) {
  const Volume v = label_volume({13, 9, 5}, DType::u64, std::uint64_t(1) << 50, 5);
  for (Extent block : {Extent{8, 8, 8}, Extent{4, 3, 2}, Extent{1, 1, 1}, Extent{16, 16, 16}}) {
    const auto encoded = encode_compressed_segmentation(v.bytes(), v.dims(), block, DType::u64);
    Volume back(v.dims(), DType::u64, v.spacing());
    decode_compressed_segmentation(encoded, v.dims(), block, 1, 0, DType::u64, back.bytes(), "chunk");
    EXPECT_TRUE(back == v) << block.to_string();
  }
}

// A box decodes only the chunks it touches: a damaged chunk elsewhere goes unnoticed until read.
// Boxes read from several threads at once come out as from one.
TEST(IoPrecomputed, BoxesReadOnlyTheirChunksFromAnyThread) {
  TempDir dir;
  const fs::path path = dir / "boxes.precomputed";
  const Volume v = random_volume({130, 70, 70}, DType::u16, 11, Spacing{1, 1, 1});
  write_volume(path, v);
  write_text(path / "1_1_1/128-130_64-70_64-70", "damaged");
  const auto source = open_volume(path);
  const Box first{{0, 0, 0}, {128, 64, 64}};
  EXPECT_TRUE(source->read_box(first) == v.crop(first));
  expect_error([&] { source->read_all(); }, {"128-130_64-70_64-70", "chunk", "7 bytes"});
  std::vector<std::thread> threads;
  std::vector<bool> same(8, false);
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&, t] {
      const Box box{{t * 10, t * 3, 5 * t}, {t * 10 + 60, t * 3 + 40, 5 * t + 20}};
      same[std::size_t(t)] = source->read_box(box) == v.crop(box);
    });
  for (auto& t : threads) t.join();
  for (int t = 0; t < 8; ++t) EXPECT_TRUE(same[std::size_t(t)]) << t;
}

TEST(IoPrecomputed, EveryScaleOfAPyramidReadsBackByLevel) {
  TempDir dir;
  const fs::path path = dir / "pyramid.precomputed";
  const Volume fine = with_geometry(random_volume({80, 70, 66}, DType::u16, 1, Spacing{8, 8, 8}), {0, 0, 0});
  const Volume coarse = with_geometry(random_volume({40, 35, 33}, DType::u16, 2, Spacing{16, 16, 16}), {16, 16, 16});
  {
    PrecomputedPyramidWriter writer(path, {fine.info(), coarse.info()});
    // Scales interleaved, slabs of uneven thickness.
    writer.level(1).write_slab(coarse.crop({{0, 0, 0}, {40, 35, 20}}));
    writer.level(0).write_slab(fine.crop({{0, 0, 0}, {80, 70, 65}}));
    writer.level(1).write_slab(coarse.crop({{0, 0, 20}, {40, 35, 33}}));
    writer.level(0).write_slab(fine.crop({{0, 0, 65}, {80, 70, 66}}));
    writer.finish();
  }
  expect_same(read_volume(path), fine);
  ReadOptions level1;
  level1.level = 1;
  const auto source = open_volume(path, level1);
  EXPECT_EQ(source->info().spacing, (Spacing{16, 16, 16}));
  expect_same(source->read_all(), coarse);
  level1.level = 2;
  expect_error([&] { open_volume(path, level1); }, {"level 2", "2 scales"});

  // The same pyramid from sources, replacing the folder.
  const auto fine_source = memory_source(fine), coarse_source = memory_source(coarse);
  VolumeSource* const sources[] = {fine_source.get(), coarse_source.get()};
  const Volume flipped = random_volume({40, 35, 33}, DType::u16, 3, Spacing{16, 16, 16});
  const auto flipped_source = memory_source(flipped);
  VolumeSource* const other[] = {fine_source.get(), flipped_source.get()};
  write_precomputed(path, other);
  write_precomputed(path, sources);
  level1.level = 1;
  expect_same(open_volume(path, level1)->read_all(), coarse);
  EXPECT_EQ(open_volume(path, level1)->info().geometry.origin, (Vector3{16, 16, 16}));
}

// A smooth 8-bit image (what JPEG is for), 2 x 1 x 1 chunks with clipped edges.
Volume smooth_u8(Extent dims) {
  Volume v(dims, DType::u8, Spacing{4, 4, 40});
  auto s = v.view<std::uint8_t>();
  for (std::int64_t z = 0; z < dims.z; ++z)
    for (std::int64_t y = 0; y < dims.y; ++y)
      for (std::int64_t x = 0; x < dims.x; ++x)
        s(x, y, z) = std::uint8_t(128 + 90 * std::sin(0.11 * double(x) + 0.05 * double(z)) * std::cos(0.07 * double(y)));
  return v;
}

double rms_error(const Volume& a, const Volume& b) {
  double sum = 0;
  const auto sa = a.samples<std::uint8_t>(), sb = b.samples<std::uint8_t>();
  for (std::size_t i = 0; i < sa.size(); ++i) sum += (double(sa[i]) - double(sb[i])) * (double(sa[i]) - double(sb[i]));
  return std::sqrt(sum / double(sa.size()));
}

TEST(IoPrecomputed, JpegChunksAreForU8ImagesAndFollowTheQuality) {
  TempDir dir;
  const Volume image = smooth_u8({70, 40, 20});
  const auto source = memory_source(image);
  double errors[2];
  std::uintmax_t chunk_bytes[2];
  const int qualities[2] = {95, 20};
  for (int i = 0; i < 2; ++i) {
    const fs::path path = dir / ("q" + std::to_string(qualities[i]) + ".precomputed");
    PrecomputedPyramidWriter writer(path, {image.info()}, PrecomputedEncoding{.jpeg_quality = qualities[i]});
    writer.level(0).write_slab(image);
    writer.finish();
    const nlohmann::json info = info_of(path);
    ASSERT_EQ(info["scales"][0]["encoding"], "jpeg");
    const std::string key = info["scales"][0]["key"];
    chunk_bytes[i] = fs::file_size(path / key / "0-64_0-40_0-20");
    errors[i] = rms_error(read_volume(path), image);

    // The served view encodes the same bytes the writer stored.
    const PrecomputedView view({image.info()}, "view", PrecomputedEncoding{.jpeg_quality = qualities[i]});
    EXPECT_EQ(view.info()["scales"][0]["encoding"], "jpeg");
    const auto chunk = view.chunk(key, "64-70_0-40_0-20");
    ASSERT_TRUE(chunk);
    EXPECT_EQ(view.encode(*chunk, image.crop(chunk->box)), test::io::read_bytes(path / key / "64-70_0-40_0-20"));
  }
  // JPEG's quantization at quality 95 (steps of 1-5 grey levels) leaves an RMS error of about a
  // grey level on a smooth image; quality 20 (steps of 20-100) several times more.
  EXPECT_LT(errors[0], 1.5);
  EXPECT_GT(errors[1], 2 * errors[0]);
  EXPECT_LT(chunk_bytes[1], chunk_bytes[0]);
  EXPECT_LT(chunk_bytes[0], std::uintmax_t(64 * 40 * 20));  // smaller than the raw chunk

  // Other sample types stay raw; segmentations stay compressed_segmentation.
  const PrecomputedView u16({random_volume({8, 8, 8}, DType::u16, 1).info()}, "u16", {.jpeg_quality = 90});
  EXPECT_EQ(u16.info()["scales"][0]["encoding"], "raw");
  const PrecomputedView u32({label_volume({8, 8, 8}, DType::u32, 0, 1).info()}, "u32", {.jpeg_quality = 90});
  EXPECT_EQ(u32.info()["scales"][0]["encoding"], "compressed_segmentation");
  EXPECT_THROW(PrecomputedView({image.info()}, "q101", {.jpeg_quality = 101}), ParameterError);
}

TEST(IoPrecomputed, AnUnfinishedWriterLeavesNothing) {
  TempDir dir;
  const fs::path path = dir / "partial.precomputed";
  {
    PrecomputedPyramidWriter writer(path, {random_volume({10, 10, 10}, DType::u8, 1).info()});
    writer.level(0).write_slab(random_volume({10, 10, 4}, DType::u8, 1));
    expect_error([&] { writer.finish(); }, {"4 of its 10 slices"});
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(dir / "partial.precomputed.tmp"));
}

// An unsharded image store written by hand: voxel offset in the chunk names, a gzip chunk, a
// missing chunk (zeros), two channels (channel slowest in the chunk) and a file outside the grid.
TEST(IoPrecomputed, HandBuiltUnshardedStoreReadsAsItsLayoutSays) {
  TempDir dir;
  const fs::path root = dir / "hand";
  fs::create_directories(root / "s0");
  write_text(root / "info", R"({"type": "image", "data_type": "uint16", "num_channels": 2, "scales": [
      {"key": "s0", "size": [6, 4, 3], "voxel_offset": [100, 200, 300], "resolution": [2, 3, 50],
       "chunk_sizes": [[4, 4, 2]], "encoding": "raw"}]})");
  // Channel c, voxel (x, y, z): 1000 c + 100 z + 10 y + x.
  const auto chunk = [](Box box) {
    std::vector<std::uint16_t> samples;
    for (int c = 0; c < 2; ++c)
      for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
        for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
          for (std::int64_t x = box.lo.x; x < box.hi.x; ++x)
            samples.push_back(std::uint16_t(1000 * c + 100 * z + 10 * y + x));
    return samples;
  };
  const auto c0 = chunk({{0, 0, 0}, {4, 4, 2}}), c1 = chunk({{4, 0, 0}, {6, 4, 2}}), c2 = chunk({{0, 0, 2}, {4, 4, 3}});
  write_bytes(root / "s0/100-104_200-204_300-302", c0.data(), c0.size() * 2);
  write_gzipped(root / "s0/104-106_200-204_300-302", c1.data(), c1.size() * 2);
  write_bytes(root / "s0/0-4_0-4_0-2", c1.data(), c1.size() * 2);  // outside the grid: never read
  write_bytes(root / "s0/100-104_200-204_302-303", c2.data(), c2.size() * 2);
  // Chunk 104-106_200-204_302-303 is missing: zeros.
  for (int channel = 0; channel < 2; ++channel) {
    ReadOptions options;
    options.volume = channel;
    const auto source = open_volume(root, options);  // a folder without the extension: detected by its info
    EXPECT_EQ(source->info().volumes, 2);
    EXPECT_EQ(source->info().spacing, (Spacing{2, 3, 50}));
    EXPECT_EQ(source->info().geometry.origin, (Vector3{200, 600, 15000}));
    const Volume v = source->read_all();
    for (std::int64_t z = 0; z < 3; ++z)
      for (std::int64_t y = 0; y < 4; ++y)
        for (std::int64_t x = 0; x < 6; ++x) {
          const double expected = x >= 4 && z == 2 ? 0 : 1000 * channel + 100 * z + 10 * y + x;
          EXPECT_EQ(v.value(x, y, z), expected) << x << "," << y << "," << z;
        }
  }
  expect_error([&] { open_volume(root); }, {"num_channels", "--volume"});
}

// A sharded segmentation store built by hand: identity hash, 2 shards of 2 minishards, gzip
// data, compressed_segmentation chunks; one chunk left out (zeros).
TEST(IoPrecomputed, HandBuiltShardedStoreReadsEveryChunkThroughItsMinishard) {
  TempDir dir;
  const fs::path root = dir / "sharded.precomputed";
  fs::create_directories(root / "8_8_8");
  write_text(root / "info",
             R"({"@type": "neuroglancer_multiscale_volume", "type": "segmentation", "data_type": "uint64",
      "num_channels": 1, "scales": [{"key": "8_8_8", "size": [8, 4, 4], "resolution": [8, 8, 8],
      "chunk_sizes": [[4, 4, 2]], "encoding": "compressed_segmentation", "compressed_segmentation_block_size": [2, 2, 2],
      "sharding": {"@type": "neuroglancer_uint64_sharded_v1", "preshift_bits": 0, "hash": "identity",
                   "minishard_bits": 1, "shard_bits": 1, "minishard_index_encoding": "raw", "data_encoding": "gzip"}}]})");
  const Volume v = label_volume({8, 4, 4}, DType::u64, std::uint64_t(1) << 45, 9);
  const ShardingSpec spec{.preshift_bits = 0,
                          .murmurhash = false,
                          .minishard_bits = 1,
                          .shard_bits = 1,
                          .gzip_minishard_index = false,
                          .gzip_data = true};
  // Grid 2 x 1 x 2: ids 0..3 (x bit, then z bit); id 3 is left out.
  struct Entry {
    std::uint64_t id;
    std::vector<std::byte> data;
  };
  std::map<std::string, std::map<std::uint64_t, std::vector<Entry>>> shards;
  for (std::uint64_t id = 0; id < 3; ++id) {
    const Extent position{std::int64_t(id & 1), 0, std::int64_t(id >> 1)};
    const Volume c = v.crop({{4 * position.x, 0, 2 * position.z}, {4 * position.x + 4, 4, 2 * position.z + 2}});
    const fs::path temp = dir / "gz";
    const auto encoded = encode_compressed_segmentation(c.bytes(), c.dims(), {2, 2, 2}, DType::u64);
    write_gzipped(temp, encoded.data(), encoded.size());
    const ShardSlot slot = shard_slot(spec, id);
    shards[slot.file_name][slot.minishard].push_back({id, test::io::read_bytes(temp)});
  }
  EXPECT_EQ(shards.size(), 2u);  // ids 0, 1, 2 -> shard bit 1 of the id: shards 0 and 1
  for (const auto& [name, minishards] : shards) {
    std::vector<std::byte> index(32), body;
    for (const auto& [minishard, entries] : minishards) {
      std::vector<std::uint64_t> ids, offsets, sizes;
      std::uint64_t previous_id = 0;
      for (const Entry& e : entries) {
        ids.push_back(e.id - previous_id);
        previous_id = e.id;
        // The first chunk's offset counts from the end of the shard index, the others from the
        // end of the previous chunk: here they follow each other.
        offsets.push_back(ids.size() == 1 ? body.size() : 0);
        sizes.push_back(e.data.size());
        body.insert(body.end(), e.data.begin(), e.data.end());
      }
      const std::uint64_t start = body.size();
      for (const auto* row : {&ids, &offsets, &sizes})
        for (std::uint64_t value : *row) {
          body.resize(body.size() + 8);
          store_field(body, body.size() - 8, value);
        }
      store_field(index, 16 * minishard, start);
      store_field(index, 16 * minishard + 8, std::uint64_t(body.size()));
    }
    index.insert(index.end(), body.begin(), body.end());
    write_bytes(root / "8_8_8" / name, index);
  }
  const Volume got = read_volume(root);
  for (std::int64_t z = 0; z < 4; ++z)
    for (std::int64_t y = 0; y < 4; ++y)
      for (std::int64_t x = 0; x < 8; ++x)
        EXPECT_EQ(got.value(x, y, z), x >= 4 && z >= 2 ? 0 : v.value(x, y, z)) << x << "," << y << "," << z;
}

TEST(IoPrecomputed, MurmurHashMatchesTheReferenceVerificationValue) {
  // SMHasher's check: hash keys {0}, {0, 1}, ... {0..254} with seeds 256 - length, then the hashes.
  std::vector<std::byte> key(256), hashes(256 * 16);
  for (int i = 0; i < 256; ++i) {
    key[std::size_t(i)] = std::byte(i);
    const auto h = murmurhash3_x86_128({key.data(), std::size_t(i)}, std::uint32_t(256 - i));
    std::memcpy(hashes.data() + 16 * i, h.data(), 16);
  }
  EXPECT_EQ(murmurhash3_x86_128(hashes, 0)[0], 0xB3ECE62Au);
}

TEST(IoPrecomputed, CompressedMortonCodesSkipTheBitsAGridDoesNotNeed) {
  EXPECT_EQ(compressed_morton_code({1, 0, 1}, {2, 2, 2}), 0b101u);
  EXPECT_EQ(compressed_morton_code({3, 0, 1}, {4, 1, 2}), 0b111u);
  EXPECT_EQ(compressed_morton_code({2, 0, 1}, {4, 1, 2}), 0b110u);
  EXPECT_EQ(compressed_morton_code({0, 0, 5}, {1, 1, 8}), 5u);
  const ShardingSpec spec{.preshift_bits = 1, .murmurhash = false, .minishard_bits = 2, .shard_bits = 5};
  const ShardSlot slot = shard_slot(spec, 0b1011011);  // >> 1: 0b101101: minishard 0b01, shard 0b1011
  EXPECT_EQ(slot.minishard, 1u);
  EXPECT_EQ(slot.file_name, "0b.shard");
}

// A store of a 4x4x2 volume in one chunk, without chunk files; `scale_members` completes its scale.
fs::path small_store(const TempDir& dir, const std::string& name, const std::string& scale_members,
                     const std::string& top = R"("type": "segmentation", "data_type": "uint32")") {
  const fs::path root = dir / (name + ".precomputed");
  fs::create_directories(root / "s");
  write_text(root / "info", "{" + top + R"(, "scales": [{"key": "s", "size": [4, 4, 2], "resolution": [1, 1, 1],
      "chunk_sizes": [[4, 4, 2]], )" +
                                scale_members + "}]}");
  return root;
}

TEST(IoPrecomputed, DamagedStoresAreRefusedNamingTheFileAndField) {
  TempDir dir;
  // A raw chunk of the wrong size.
  const fs::path wrong = small_store(dir, "wrong", R"("encoding": "raw")");
  write_bytes(wrong / "s/0-4_0-4_0-2", std::vector<std::byte>(100));
  expect_error([&] { read_volume(wrong); }, {"0-4_0-4_0-2", "chunk", "100 bytes", "128"});
  // Sizes whose product overflows.
  const fs::path huge = dir / "huge.precomputed";
  fs::create_directories(huge);
  write_text(huge / "info", R"({"type": "image", "data_type": "uint64", "scales": [{"key": "s",
      "size": [140737488355328, 140737488355328, 140737488355328], "resolution": [1, 1, 1],
      "chunk_sizes": [[64, 64, 64]], "encoding": "raw"}]})");
  expect_error([&] { open_volume(huge); }, {"info", "scales[0].size"});
  // Chunks larger than a chunk may be.
  const fs::path big = small_store(dir, "big", R"("encoding": "raw")");
  write_text(big / "info", R"({"type": "image", "data_type": "uint8", "scales": [{"key": "s", "size": [4, 4, 4],
      "resolution": [1, 1, 1], "chunk_sizes": [[100000, 100000, 100000]], "encoding": "raw"}]})");
  expect_error([&] { open_volume(big); }, {"info", "scales[0].chunk_sizes"});
  write_text(big / "info", R"({"type": "image", "data_type": "uint8", "scales": [{"key": "s", "size": [4, 4, 4],
      "resolution": [1, 1, 1], "chunk_sizes": [[4398046511104, 4398046511104, 4398046511104]], "encoding": "raw"}]})");
  expect_error([&] { open_volume(big); }, {"info", "scales[0].chunk_sizes"});
  // A key leaving the folder; missing and wrong members.
  write_text(big / "info", R"({"type": "image", "data_type": "uint8", "scales": [{"key": "../../etc", "size": [4, 4, 4],
      "resolution": [1, 1, 1], "chunk_sizes": [[4, 4, 4]], "encoding": "raw"}]})");
  expect_error([&] { open_volume(big); }, {"info", "scales[0].key", "leaves"});
  write_text(big / "info", R"({"type": "image", "scales": []})");
  expect_error([&] { open_volume(big); }, {"info", "data_type", "missing"});
  write_text(big / "info", R"({"type": "image", "data_type": "float64", "scales": []})");
  expect_error([&] { open_volume(big); }, {"info", "data_type", "float64"});
  expect_error([&] { open_volume(small_store(dir, "jpeg32", R"("encoding": "jpeg")")); },
               {"scales[0].encoding", "uint8"});
  // Huge and deeply nested JSON.
  write_text(big / "info", "{\"type\": \"image\", \"pad\": \"" + std::string(2 << 20, 'x') + "\"}");
  expect_error([&] { open_volume(big); }, {"info", "bytes"});
  write_text(big / "info", "{\"scales\": " + std::string(100000, '[') + std::string(100000, ']') + "}");
  expect_error([&] { open_volume(big); }, {"info", "nested"});
  // compressed_segmentation offsets out of range.
  const fs::path cseg =
      small_store(dir, "cseg",
                  R"("encoding": "compressed_segmentation", "compressed_segmentation_block_size": [4, 4, 2])");
  std::vector<std::byte> chunk(4 * 4);
  store_field(chunk, 0, std::uint32_t(1));                 // channel 0 at word 1
  store_field(chunk, 4, std::uint32_t(900) | (1u << 24));  // table at word 900: past the end
  store_field(chunk, 8, std::uint32_t(3));
  write_bytes(cseg / "s/0-4_0-4_0-2", chunk);
  expect_error([&] { read_volume(cseg); }, {"0-4_0-4_0-2", "compressed_segmentation", "900"});
  store_field(chunk, 4, std::uint32_t(2) | (3u << 24));  // 3 encoded bits
  write_bytes(cseg / "s/0-4_0-4_0-2", chunk);
  expect_error([&] { read_volume(cseg); }, {"compressed_segmentation", "3 encoded bits"});
  // A shard index pointing past the file.
  const fs::path sharded =
      small_store(dir, "shard", R"("encoding": "raw", "sharding": {"@type": "neuroglancer_uint64_sharded_v1",
      "hash": "identity", "minishard_bits": 0, "shard_bits": 0})");
  std::vector<std::byte> shard(16 + 8);
  store_field(shard, 0, std::uint64_t(0));
  store_field(shard, 8, std::uint64_t(4096));
  write_bytes(sharded / "s/0.shard", shard);
  expect_error([&] { read_volume(sharded); }, {".shard", "shard index", "4096"});
  // A minishard index whose chunk lies past the file.
  std::vector<std::byte> listed(16 + 24);
  store_field(listed, 8, std::uint64_t(24));
  store_field(listed, 16, std::uint64_t(0));     // chunk id 0
  store_field(listed, 24, std::uint64_t(1000));  // offset
  store_field(listed, 32, std::uint64_t(128));   // size
  write_bytes(sharded / "s/0.shard", listed);
  expect_error([&] { read_volume(sharded); }, {".shard", "minishard index", "outside the file"});
  // An unknown hash.
  expect_error(
      [&] {
        open_volume(small_store(dir, "hash", R"("encoding": "raw", "sharding": {"hash": "md5",
      "minishard_bits": 0, "shard_bits": 0})"));
      },
      {"scales[0].sharding.hash", "md5"});
}

TEST(IoPrecomputed, FoldersAreDetectedByTheirInfoFile) {
  TempDir dir;
  const fs::path store = small_store(dir, "detect", R"("encoding": "raw")");
  const fs::path plain = dir / "plain";
  fs::rename(store, plain);
  EXPECT_EQ(detect_format(plain).name, "precomputed");
  EXPECT_EQ(read_volume(plain).dims(), (Extent{4, 4, 2}));  // no chunk files: zeros
}

}  // namespace
}  // namespace strata::io
