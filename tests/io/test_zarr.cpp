// Zarr and OME-Zarr: what the writer stores reads back with its geometry (every sample type, a
// pyramid of levels); hand-made v2 and v3 stores (F order, big-endian samples, "/" keys, fill
// values and missing chunks, transpose, t/c axes, composed transforms) read by their metadata;
// damaged metadata and chunks refused naming the file and field.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "strata/core/error.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/ome_zarr.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"
#include "io/io_test_util.hpp"
#include "io/zarr_test_util.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::error_of;
using test::TempDir;
using test::zarr::expect_refused;

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

template <class T>
void write_samples(const fs::path& path, const std::vector<T>& values, bool big_endian = false) {
  fs::create_directories(path.parent_path());
  std::vector<char> bytes(values.size() * sizeof(T));
  std::memcpy(bytes.data(), values.data(), bytes.size());
  if (big_endian)
    for (std::size_t i = 0; i < values.size(); ++i) std::reverse(bytes.begin() + std::ptrdiff_t(i * sizeof(T)), bytes.begin() + std::ptrdiff_t((i + 1) * sizeof(T)));
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

json v2_array(json shape, json chunks, std::string dtype, json extra = json::object()) {
  json j = {{"zarr_format", 2}, {"shape", shape}, {"chunks", chunks}, {"dtype", dtype}, {"compressor", nullptr},
            {"fill_value", 0},  {"order", "C"},   {"filters", nullptr}};
  j.update(extra);
  return j;
}

template <class T>
T at(const Volume& v, std::int64_t x, std::int64_t y, std::int64_t z) {
  const Extent& d = v.dims();
  return v.samples<T>()[std::size_t((z * d.y + y) * d.x + x)];
}

TEST(IoZarr, WrittenOmeZarrReadsBackWithGeometryForEveryType) {
  TempDir dir;
  for (DType t : kAllDTypes)
    for (bool compress : {true, false}) {
      // 70 x 66 x 67: every axis has a partial edge chunk of the 64^3 grid.
      Volume v = test::io::random_volume({70, 66, 67}, t, 7, {0.5, 1.25, 2.0});
      VolumeInfo info = v.info();
      info.geometry.origin = {10.0, -3.5, 7.25};
      info.geometry.unit = "um";
      const fs::path path = dir / (std::string(dtype_name(t)) + (compress ? "c" : "") + ".ome.zarr");
      auto writer = create_volume_writer(path, info, test::io::with_compression(compress));
      writer->write_slab(v.crop(Box{{0, 0, 0}, {70, 66, 30}}));
      writer->write_slab(v.crop(Box{{0, 0, 30}, {70, 66, 67}}));
      writer->finish();
      EXPECT_FALSE(fs::exists(path.string() + ".tmp"));
      auto source = open_volume(path);
      EXPECT_EQ(source->info().spacing, (Spacing{0.5, 1.25, 2.0}));
      EXPECT_EQ(source->info().geometry.origin, (Vector3{10.0, -3.5, 7.25}));
      EXPECT_EQ(source->info().geometry.unit, "um");
      test::io::expect_same(source->read_all(), v, path.string());
      // A box across chunk borders.
      const Box box{{60, 1, 62}, {69, 65, 66}};
      EXPECT_TRUE(source->read_box(box) == v.crop(box)) << path;
    }
}

TEST(IoZarr, SlabsThroughOneChunkRowDecodeEachChunkOnce) {
  TempDir dir;
  const Volume v = test::io::random_volume({40, 30, 8}, DType::u16, 5);
  const fs::path path = dir / "s.ome.zarr";
  write_volume(path, v);
  auto source = open_volume(path);
  EXPECT_TRUE(source->read_slab(0, 1) == v.crop(Box{{0, 0, 0}, {40, 30, 1}}));
  // The chunk row is cached: with its files gone the next slabs still read the samples, where a
  // reader that went back to the files would find them missing and return the fill value 0.
  fs::remove_all(path / "0" / "0");
  EXPECT_TRUE(source->read_slab(1, 8) == v.crop(Box{{0, 0, 1}, {40, 30, 8}}));
  EXPECT_EQ(open_volume(path)->read_slab(1, 2).samples<std::uint16_t>()[0], 0);
}

TEST(IoZarr, AttributesAreNgff04WithScaleAndTranslationInZyxOrder) {
  TempDir dir;
  VolumeInfo info{.dims = {3, 4, 5}, .dtype = DType::u16, .spacing = {0.5, 1.25, 2.0}};
  info.geometry.origin = {1, 2, 3};
  info.geometry.unit = "nm";
  write_volume(dir / "a.ome.zarr", Volume(info));
  std::ifstream in(dir / "a.ome.zarr" / ".zattrs");
  const json attrs = json::parse(in);
  const json& ms = attrs["multiscales"][0];
  EXPECT_EQ(ms["version"], "0.4");
  EXPECT_EQ(ms["axes"][0]["name"], "z");
  EXPECT_EQ(ms["axes"][2]["unit"], "nanometer");
  EXPECT_EQ(ms["datasets"][0]["path"], "0");
  EXPECT_EQ(ms["datasets"][0]["coordinateTransformations"][0]["scale"], json({2.0, 1.25, 0.5}));
  EXPECT_EQ(ms["datasets"][0]["coordinateTransformations"][1]["translation"], json({3.0, 2.0, 1.0}));
  std::ifstream za(dir / "a.ome.zarr" / "0" / ".zarray");
  const json zarray = json::parse(za);
  EXPECT_EQ(zarray["shape"], json({5, 4, 3}));
  EXPECT_EQ(zarray["dtype"], "<u2");
}

TEST(IoZarr, PyramidWritesEveryLevelWithItsTransform) {
  TempDir dir;
  Volume fine = test::io::random_volume({8, 6, 4}, DType::u64, 3, {1, 1, 1});
  Volume coarse = test::io::random_volume({4, 3, 2}, DType::u64, 4, {2, 2, 2});
  auto a = memory_source(fine), b = memory_source(coarse);
  const fs::path path = dir / "p.ome.zarr";
  write_ome_zarr_pyramid(path, {a.get(), b.get()});
  test::io::expect_same(read_volume(path), fine);
  ReadOptions level1;
  level1.level = 1;
  test::io::expect_same(read_volume(path, level1), coarse);
  level1.level = 2;
  EXPECT_EQ(test::parameter_of([&] { (void)open_volume(path, level1); }), "ReadOptions::level");
  EXPECT_EQ(test::parameter_of([&] { write_ome_zarr_pyramid(dir / "none.ome.zarr", {}); }), "levels");
}

TEST(IoZarr, HandMadeV2FortranOrderBigEndianSlashKeysAndFill) {
  TempDir dir;
  const fs::path store = dir / "f.zarr";
  // shape (z, y, x) = (2, 3, 5), chunks (2, 3, 3): two chunks along x; the second is missing.
  write_text(store / ".zarray",
             v2_array({2, 3, 5}, {2, 3, 3}, ">u8", {{"order", "F"}, {"fill_value", 7}, {"dimension_separator", "/"}}).dump());
  // F order: x fastest inside the chunk... reversed axes: the stored chunk is (x, y, z) in C
  // order, so z varies fastest. Value = id above 2^40 encoding (x, y, z).
  std::vector<std::uint64_t> chunk;
  const std::uint64_t big = std::uint64_t(1) << 41;
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      for (int z = 0; z < 2; ++z) chunk.push_back(big + std::uint64_t(100 * z + 10 * y + x));
  write_samples(store / "0" / "0" / "0", chunk, true);
  const Volume v = read_volume(store);
  ASSERT_EQ(v.dims(), (Extent{5, 3, 2}));
  ASSERT_EQ(v.dtype(), DType::u64);
  EXPECT_EQ(at<std::uint64_t>(v, 2, 1, 1), big + 112);
  EXPECT_EQ(at<std::uint64_t>(v, 0, 2, 0), big + 20);
  EXPECT_EQ(at<std::uint64_t>(v, 3, 0, 0), 7u);  // missing chunk: the fill value
  EXPECT_EQ(at<std::uint64_t>(v, 4, 2, 1), 7u);
}

TEST(IoZarr, HandMadeV3DefaultKeysTransposeAndNanFill) {
  TempDir dir;
  const fs::path store = dir / "v3.zarr";
  const json meta = {{"zarr_format", 3},
                     {"node_type", "array"},
                     {"shape", {2, 2, 4}},
                     {"data_type", "float32"},
                     {"chunk_grid", {{"name", "regular"}, {"configuration", {{"chunk_shape", {2, 2, 2}}}}}},
                     {"chunk_key_encoding", {{"name", "default"}}},
                     {"fill_value", "NaN"},
                     {"codecs", json::array({{{"name", "transpose"}, {"configuration", {{"order", {2, 1, 0}}}}},
                                             {{"name", "bytes"}, {"configuration", {{"endian", "big"}}}}})}};
  write_text(store / "zarr.json", meta.dump());
  std::vector<float> chunk;  // stored axes (x, y, z): z fastest
  for (int x = 0; x < 2; ++x)
    for (int y = 0; y < 2; ++y)
      for (int z = 0; z < 2; ++z) chunk.push_back(float(100 * z + 10 * y + x));
  write_samples(store / "c" / "0" / "0" / "0", chunk, true);
  const Volume v = read_volume(store);
  ASSERT_EQ(v.dims(), (Extent{4, 2, 2}));
  EXPECT_EQ(at<float>(v, 1, 0, 1), 101.0f);
  EXPECT_EQ(at<float>(v, 0, 1, 0), 10.0f);
  EXPECT_TRUE(std::isnan(at<float>(v, 2, 0, 0)));
}

// A 5-D (t, c, z, y, x) OME-Zarr 0.4 image with two levels and transforms at both levels.
fs::path five_d_image(const fs::path& dir) {
  const fs::path image = dir / "t.ome.zarr";
  write_text(image / ".zgroup", R"({"zarr_format": 2})");
  const json axes = json::array({{{"name", "t"}, {"type", "time"}},
                                 {{"name", "c"}, {"type", "channel"}},
                                 {{"name", "z"}, {"type", "space"}, {"unit", "micrometer"}},
                                 {{"name", "y"}, {"type", "space"}, {"unit", "micrometer"}},
                                 {{"name", "x"}, {"type", "space"}, {"unit", "micrometer"}}});
  const auto transforms = [](json scale, json translation) {
    return json::array({{{"type", "scale"}, {"scale", scale}}, {{"type", "translation"}, {"translation", translation}}});
  };
  const json attrs = {{"multiscales",
                       {{{"version", "0.4"},
                         {"axes", axes},
                         {"datasets",
                          {{{"path", "0"}, {"coordinateTransformations", transforms({1, 1, 2, 3, 4}, {0, 0, 1, 1, 1})}},
                           {{"path", "1"}, {"coordinateTransformations", transforms({1, 1, 4, 6, 8}, {0, 0, 2, 2, 2})}}}},
                         {"coordinateTransformations", transforms({1, 1, 0.5, 0.5, 0.5}, {0, 0, 10, 20, 30})}}}}};
  write_text(image / ".zattrs", attrs.dump());
  // Level 0: t 2, c 3, 1 x 2 x 2, one chunk per (t, c) volume of value 10 t + c.
  write_text(image / "0" / ".zarray", v2_array({2, 3, 1, 2, 2}, {1, 1, 1, 2, 2}, "<i2").dump());
  for (int t = 0; t < 2; ++t)
    for (int c = 0; c < 3; ++c)
      write_samples(image / "0" / fmt::format("{}.{}.0.0.0", t, c), std::vector<std::int16_t>(4, std::int16_t(10 * t + c)));
  write_text(image / "1" / ".zarray", v2_array({2, 3, 1, 1, 1}, {1, 1, 1, 1, 1}, "<i2").dump());
  return image;
}

TEST(IoZarr, OmeTimeAndChannelAxesAreVolumesAndTransformsCompose) {
  TempDir dir;
  const fs::path image = five_d_image(dir.path());
  ReadOptions options;
  options.volume = 4;  // t 1, c 1 (t slowest)
  auto source = open_volume(image, options);
  EXPECT_EQ(source->info().volumes, 6);
  EXPECT_EQ(source->info().dims, (Extent{2, 2, 1}));
  EXPECT_EQ(at<std::int16_t>(source->read_all(), 1, 1, 0), 11);
  // Dataset scale then the multiscale's: x 4 * 0.5, origin 0.5 * 1 + 30.
  EXPECT_EQ(source->info().spacing, (Spacing{2.0, 1.5, 1.0}));
  EXPECT_EQ(source->info().geometry.origin, (Vector3{30.5, 20.5, 10.5}));
  EXPECT_EQ(source->info().geometry.unit, "um");
  options.level = 1;
  auto coarse = open_volume(image, options);
  EXPECT_EQ(coarse->info().spacing, (Spacing{4.0, 3.0, 2.0}));
  EXPECT_EQ(at<std::int16_t>(coarse->read_all(), 0, 0, 0), 0);  // no chunks written: fill 0
  EXPECT_NE(error_of([&] { (void)open_volume(image); }).find("--volume"), std::string::npos);
}

TEST(IoZarr, DatasetChoosesAnArrayOfAGroup) {
  TempDir dir;
  const fs::path store = dir / "g.zarr";
  write_text(store / ".zgroup", R"({"zarr_format": 2})");
  write_text(store / "raw" / ".zarray", v2_array({1, 1, 2}, {1, 1, 2}, "|u1").dump());
  write_samples(store / "raw" / "0.0.0", std::vector<std::uint8_t>{5, 6});
  write_text(store / "labels" / "cells" / ".zarray", v2_array({1, 1, 1}, {1, 1, 1}, "<u4").dump());
  write_text(store / "other" / ".zarray", v2_array({1, 1, 1}, {1, 1, 1}, "<u4").dump());
  const std::string message = error_of([&] { (void)open_volume(store); });
  EXPECT_NE(message.find("other, raw"), std::string::npos) << message;
  ReadOptions options;
  options.dataset = "/raw";
  EXPECT_EQ(at<std::uint8_t>(read_volume(store, options), 1, 0, 0), 6);
  EXPECT_EQ(read_volume(fs::path(store.string() + ":/labels/cells")).dtype(), DType::u32);
}

TEST(IoZarr, HostileMetadataAndChunksAreRefusedNamingFileAndField) {
  TempDir dir;
  const auto store = [&](const std::string& name, const json& meta) {
    write_text(dir / name / ".zarray", meta.dump());
    return dir / name;
  };
  const auto open = [](const fs::path& p) { return [p] { (void)read_volume(p); }; };
  const std::int64_t huge = std::int64_t(1) << 40;
  expect_refused(open(store("overflow.zarr", v2_array({huge, huge, huge}, {1, 1, 1}, "<u2"))), ".zarray", "shape");
  expect_refused(open(store("bigchunk.zarr", v2_array({4, 4, 4}, {huge, huge, 1}, "<u2"))), ".zarray", "chunks");
  expect_refused(open(store("dtype.zarr", v2_array({4, 4, 4}, {4, 4, 4}, "<c8"))), ".zarray", "dtype");
  expect_refused(open(store("rank.zarr", v2_array({4}, {4}, "<u2"))), ".zarray", "shape");
  json no_shape = v2_array({4, 4, 4}, {4, 4, 4}, "<u2");
  no_shape.erase("shape");
  expect_refused(open(store("noshape.zarr", no_shape)), ".zarray", "shape: missing");
  expect_refused(open(store("codec.zarr", v2_array({4, 4, 4}, {4, 4, 4}, "<u2", {{"compressor", {{"id", "lzma"}}}}))),
                 ".zarray", "compressor");
  expect_refused(open(store("fill.zarr", v2_array({4, 4, 4}, {4, 4, 4}, "|u1", {{"fill_value", 300}}))), ".zarray",
                 "fill_value");
  // Recursive and huge JSON.
  write_text(dir / "deep.zarr" / ".zarray", std::string(100000, '[') + std::string(100000, ']'));
  expect_refused(open(dir / "deep.zarr"), ".zarray", "nested");
  write_text(dir / "huge.zarr" / ".zarray", "{\"a\": \"" + std::string(17 << 20, 'x') + "\"}");
  expect_refused(open(dir / "huge.zarr"), ".zarray", "bytes of JSON");
  // A truncated chunk, and compressed chunks that are not what they say.
  const fs::path truncated = store("short.zarr", v2_array({2, 2, 2}, {2, 2, 2}, "<u2"));
  write_samples(truncated / "0.0.0", std::vector<std::uint16_t>(7, 1));
  expect_refused(open(truncated), "0.0.0", "chunk: decodes to 14 bytes");
  for (const char* id : {"zstd", "blosc", "gzip"}) {
    const fs::path damaged = store(std::string(id) + ".zarr", v2_array({2, 2, 2}, {2, 2, 2}, "<u2", {{"compressor", {{"id", id}}}}));
    write_samples(damaged / "0.0.0", std::vector<std::uint16_t>(40, 0x4242));
    expect_refused(open(damaged), "0.0.0", "chunk");
  }
  // OME paths that leave the image, and a group with nothing in it.
  write_text(dir / "escape.zarr" / ".zattrs", R"({"multiscales": [{"datasets": [{"path": "../x"}]}]})");
  expect_refused(open(dir / "escape.zarr"), "escape.zarr", "multiscales.datasets.path");
  write_text(dir / "empty.zarr" / ".zgroup", R"({"zarr_format": 2})");
  expect_refused(open(dir / "empty.zarr"), "empty.zarr", "dataset");
}

TEST(IoZarr, FoldersAreDetectedByTheirMetadata) {
  TempDir dir;
  write_text(dir / "plain" / ".zarray", v2_array({1, 1, 1}, {1, 1, 1}, "|u1").dump());
  EXPECT_EQ(detect_format(dir / "plain").name, "zarr");
  fs::create_directories(dir / "x.ome.zarr");
  EXPECT_EQ(detect_format(dir / "x.ome.zarr").name, "zarr");
}

}  // namespace
}  // namespace strata::io
