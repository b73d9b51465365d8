// TIFF stacks: round trips for every dtype as one multi-page file and as a folder of slices,
// files written directly with libtiff (strips, tiles, compression, big endian), natural slice
// order, page consistency errors, spacing in ImageDescription, and lazy page reading.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <random>

#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata {
namespace {

namespace fs = std::filesystem;
using test::TempDir;
using namespace test::io;

// ---------------------------------------------------------------------------------------------
// Writing test files with libtiff directly, independently of the writer under test.

struct PageSpec {
  std::uint32_t width = 8, height = 6;
  std::uint16_t bits = 8, sample_format = SAMPLEFORMAT_UINT, samples = 1;
  std::uint16_t compression = COMPRESSION_NONE, predictor = PREDICTOR_NONE;
  std::uint32_t rows_per_strip = 0;  // 0: the whole page in one strip
  std::uint32_t tile = 0;            // > 0: square tiles of this size instead of strips
  bool planar = false;               // channels in planes of their own (data: one plane after another)
  std::string description;
  std::vector<std::byte> data;  // rows top to bottom

  std::size_t row_bytes() const { return std::size_t(width) * samples * bits / 8; }
  std::size_t plane_row_bytes() const { return std::size_t(width) * bits / 8; }
};

std::vector<std::byte> random_bytes(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::byte> b(n);
  for (auto& x : b) x = std::byte(rng() & 0xff);
  return b;
}

PageSpec page_of(std::uint32_t width, std::uint32_t height, std::uint16_t bits, std::uint16_t sample_format,
                 std::uint64_t seed) {
  PageSpec p;
  p.width = width;
  p.height = height;
  p.bits = bits;
  p.sample_format = sample_format;
  p.data = random_bytes(p.row_bytes() * height, seed);
  return p;
}

void write_strips(TIFF* tif, const PageSpec& p) {
  const std::uint32_t rows = p.rows_per_strip ? p.rows_per_strip : p.height;
  TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, rows);
  if (p.planar) {
    const std::size_t row = p.plane_row_bytes(), plane = row * p.height;
    for (tsample_t c = 0; c < p.samples; ++c)
      for (std::uint32_t y = 0; y < p.height; y += rows) {
        const std::uint32_t n = std::min(rows, p.height - y);
        std::vector<std::byte> buffer(p.data.begin() + std::ptrdiff_t(c * plane + y * row),
                                      p.data.begin() + std::ptrdiff_t(c * plane + (y + n) * row));
        ASSERT_GE(TIFFWriteEncodedStrip(tif, TIFFComputeStrip(tif, y, c), buffer.data(), tmsize_t(buffer.size())), 0);
      }
    return;
  }
  for (std::uint32_t y = 0, strip = 0; y < p.height; y += rows, ++strip) {
    const std::uint32_t n = std::min(rows, p.height - y);
    std::vector<std::byte> buffer(p.data.begin() + std::ptrdiff_t(y * p.row_bytes()),
                                  p.data.begin() + std::ptrdiff_t((y + n) * p.row_bytes()));
    ASSERT_GE(TIFFWriteEncodedStrip(tif, strip, buffer.data(), tmsize_t(buffer.size())), 0);
  }
}

void write_tiles(TIFF* tif, const PageSpec& p) {
  TIFFSetField(tif, TIFFTAG_TILEWIDTH, p.tile);
  TIFFSetField(tif, TIFFTAG_TILELENGTH, p.tile);
  const std::size_t sample = std::size_t(p.bits / 8) * p.samples, tile_row = p.tile * sample;  // a pixel's bytes
  for (std::uint32_t ty = 0; ty < p.height; ty += p.tile)
    for (std::uint32_t tx = 0; tx < p.width; tx += p.tile) {
      std::vector<std::byte> tile(tile_row * p.tile);  // edge tiles padded with zeros
      for (std::uint32_t y = ty; y < std::min(p.height, ty + p.tile); ++y) {
        const std::uint32_t n = std::min(p.tile, p.width - tx);
        std::memcpy(tile.data() + (y - ty) * tile_row, p.data.data() + y * p.row_bytes() + tx * sample, n * sample);
      }
      ASSERT_GE(TIFFWriteEncodedTile(tif, TIFFComputeTile(tif, tx, ty, 0, 0), tile.data(), tmsize_t(tile.size())), 0);
    }
}

// mode "w" (little endian), "wb" (big endian), "w8" (BigTIFF).
void write_pages(const fs::path& path, const std::vector<PageSpec>& pages, const char* mode = "w") {
  TIFF* tif = TIFFOpen(path.c_str(), mode);
  ASSERT_NE(tif, nullptr);
  for (const PageSpec& p : pages) {
    TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, p.width);
    TIFFSetField(tif, TIFFTAG_IMAGELENGTH, p.height);
    TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, p.bits);
    TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, p.samples);
    TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, p.sample_format);
    TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, p.samples == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
    TIFFSetField(tif, TIFFTAG_PLANARCONFIG, p.planar ? PLANARCONFIG_SEPARATE : PLANARCONFIG_CONTIG);
    TIFFSetField(tif, TIFFTAG_COMPRESSION, p.compression);
    if (p.predictor != PREDICTOR_NONE) TIFFSetField(tif, TIFFTAG_PREDICTOR, p.predictor);
    if (!p.description.empty()) TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, p.description.c_str());
    if (p.tile)
      write_tiles(tif, p);
    else
      write_strips(tif, p);
    ASSERT_EQ(TIFFWriteDirectory(tif), 1);
  }
  TIFFClose(tif);
}

// The volume the pages describe (all pages the same size and type).
Volume volume_of(const std::vector<PageSpec>& pages, DType dtype) {
  Volume v({pages[0].width, pages[0].height, std::int64_t(pages.size())}, dtype);
  std::size_t offset = 0;
  for (const PageSpec& p : pages) {
    std::memcpy(v.bytes() + offset, p.data.data(), p.data.size());
    offset += p.data.size();
  }
  return v;
}

// Tags of page `index` of a file, read with libtiff.
struct PageTags {
  std::uint16_t compression = 0;
  std::string description;
  tdir_t pages = 0;
};
PageTags tags_of(const fs::path& path, tdir_t index) {
  PageTags t;
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  if (!tif) return t;
  t.pages = TIFFNumberOfDirectories(tif);
  TIFFSetDirectory(tif, index);
  TIFFGetField(tif, TIFFTAG_COMPRESSION, &t.compression);
  const char* text = nullptr;
  if (TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &text) == 1) t.description = text;
  TIFFClose(tif);
  return t;
}

// ---------------------------------------------------------------------------------------------
// Round trips through our writer

struct RoundTripCase {
  DType dtype;
  bool folder;
  bool compress;
};

class IoTiffRoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(IoTiffRoundTrip, IsBitExactWithSpacingAndBoxes) {
  const auto [dtype, folder, compress] = GetParam();
  TempDir dir;
  const fs::path path = folder ? dir / "slices" : dir / "stack.tif";
  const Volume original = random_volume({9, 7, 5}, dtype, 17);
  // A new folder has no extension to detect the format from.
  const io::WriteOptions options{.compress = compress, .format = "tiff"};
  {
    auto writer = io::create_volume_writer(path, original.info(), options);
    writer->write_slab(original.crop({{0, 0, 0}, {9, 7, 3}}));
    writer->write_slab(original.crop({{0, 0, 3}, {9, 7, 5}}));
    writer->finish();
  }
  expect_same(io::read_volume(path), original);
  // Pages visited out of order and partial rows/columns.
  auto source = io::open_volume(path);
  for (const Box& box : {Box{{2, 1, 4}, {8, 6, 5}}, Box{{0, 3, 1}, {4, 4, 3}}, Box{{5, 0, 0}, {9, 7, 2}}})
    EXPECT_TRUE(source->read_box(box) == original.crop(box)) << box.to_string();

  const fs::path first_page = folder ? path / "slice_0000.tif" : path;
  EXPECT_EQ(tags_of(first_page, 0).compression, compress ? COMPRESSION_ADOBE_DEFLATE : COMPRESSION_NONE);
}

std::vector<RoundTripCase> round_trip_cases() {
  std::vector<RoundTripCase> cases;
  for (DType t : kAllDtypes)
    for (bool folder : {false, true})
      for (bool compress : {false, true}) cases.push_back({t, folder, compress});
  return cases;
}

INSTANTIATE_TEST_SUITE_P(AllTypes, IoTiffRoundTrip, ::testing::ValuesIn(round_trip_cases()), [](const auto& info) {
  return std::string(dtype_name(info.param.dtype)) + (info.param.folder ? "_folder" : "_multipage") +
         (info.param.compress ? "_deflate" : "_plain");
});

TEST(IoTiff, MultiPageFileHasOnePagePerSliceAndSpacingJson) {
  TempDir dir;
  const Volume v = random_volume({6, 4, 7}, DType::u16, 2, {0.25, 0.5, 3.0});
  io::write_volume(dir / "s.tiff", v);
  const PageTags tags = tags_of(dir / "s.tiff", 6);
  EXPECT_EQ(tags.pages, 7u);
  EXPECT_EQ(tags.description, R"({"spacing":[0.25,0.5,3.0]})");
  EXPECT_FALSE(fs::exists(dir / "s.tiff.tmp"));
}

TEST(IoTiff, FolderWriterNamesSlicesAndLeavesNoStaging) {
  TempDir dir;
  fs::create_directory(dir / "out");  // an existing folder is detected as a TIFF stack
  const Volume v = random_volume({5, 3, 12}, DType::f32, 4);
  io::write_volume(dir / "out", v);
  EXPECT_EQ(file_count(dir / "out"), 12u);
  EXPECT_TRUE(fs::exists(dir / "out" / "slice_0000.tif"));
  EXPECT_TRUE(fs::exists(dir / "out" / "slice_0011.tif"));
  EXPECT_EQ(tags_of(dir / "out" / "slice_0003.tif", 0).pages, 1u);
  EXPECT_EQ(file_count(dir.path()), 1u);  // no out.tmp left behind
}

TEST(IoTiff, FolderWriterReplacesOldSlicesButNotOtherFiles) {
  TempDir dir;
  const io::WriteOptions options{.format = "tiff"};
  io::write_volume(dir / "out", random_volume({4, 4, 9}, DType::u8, 1), options);
  const Volume small = random_volume({4, 4, 3}, DType::u8, 2);
  io::write_volume(dir / "out", small, options);
  EXPECT_EQ(file_count(dir / "out"), 3u);  // no stale slice_0003..8 mixed in
  EXPECT_TRUE(io::read_volume(dir / "out") == small);

  std::ofstream(dir / "out" / "notes.txt") << "keep me";
  expect_error([&] { io::write_volume(dir / "out", small, options); }, {"out", "notes.txt"});
  EXPECT_TRUE(fs::exists(dir / "out" / "notes.txt"));
}

TEST(IoTiff, UnfinishedWritersLeaveNothing) {
  TempDir dir;
  const Volume v = random_volume({4, 4, 4}, DType::u16, 3);
  const io::WriteOptions options{.format = "tiff"};
  for (const char* name : {"stack.tif", "folder"}) {
    {
      auto writer = io::create_volume_writer(dir / name, v.info(), options);
      writer->write_slab(v.crop({{0, 0, 0}, {4, 4, 2}}));
    }  // destroyed without finish()
    EXPECT_FALSE(fs::exists(dir / name)) << name;
  }
  EXPECT_EQ(file_count(dir.path()), 0u);
}

// ---------------------------------------------------------------------------------------------
// Files from other writers

TEST(IoTiff, FolderSlicesAreInNaturalOrder) {
  TempDir dir;
  fs::create_directory(dir / "stack");
  std::vector<PageSpec> pages;
  for (int index : {1, 2, 10, 99, 100}) {
    PageSpec p = page_of(4, 3, 8, SAMPLEFORMAT_UINT, 0);
    std::fill(p.data.begin(), p.data.end(), std::byte(index));
    write_pages(dir / "stack" / ("slice_" + std::to_string(index) + ".tif"), {p});
    pages.push_back(p);
  }
  std::ofstream(dir / "stack" / "readme.txt") << "not a slice";
  write_pages(dir / "stack" / "._slice_5.tif", {page_of(9, 9, 16, SAMPLEFORMAT_UINT, 1)});  // macOS metadata
  const Volume v = io::read_volume(dir / "stack");
  ASSERT_EQ(v.dims(), (Extent{4, 3, 5}));
  EXPECT_TRUE(v == volume_of(pages, DType::u8));
  EXPECT_EQ(v.value(0, 0, 2), 10.0);  // lexicographic order would put slice_10 second
  EXPECT_EQ(v.spacing(), Spacing{});  // no description: default spacing
}

TEST(IoTiff, ReadsTiledCompressedPages) {
  TempDir dir;
  std::vector<PageSpec> pages;
  for (std::uint64_t z = 0; z < 3; ++z) {
    PageSpec p = page_of(40, 24, 16, SAMPLEFORMAT_UINT, z);
    p.tile = 16;  // 3x2 tiles, the right and bottom ones partly outside the page
    p.compression = COMPRESSION_LZW;
    pages.push_back(p);
  }
  write_pages(dir / "tiled.tif", pages);
  const Volume expected = volume_of(pages, DType::u16);
  auto source = io::open_volume(dir / "tiled.tif");
  EXPECT_TRUE(source->read_all() == expected);
  const Box box{{13, 15, 1}, {35, 20, 3}};  // crosses tile borders in x and y
  EXPECT_TRUE(source->read_box(box) == expected.crop(box));
}

TEST(IoTiff, ReadsBigEndianStripsWithPredictor) {
  TempDir dir;
  std::vector<PageSpec> pages;
  for (std::uint64_t z = 0; z < 4; ++z) {
    PageSpec p = page_of(11, 10, 32, SAMPLEFORMAT_INT, 100 + z);
    p.rows_per_strip = 3;  // 4 strips, the last one short
    p.compression = COMPRESSION_ADOBE_DEFLATE;
    p.predictor = PREDICTOR_HORIZONTAL;
    pages.push_back(p);
  }
  write_pages(dir / "be.tif", pages, "wb");
  const Volume expected = volume_of(pages, DType::i32);
  auto source = io::open_volume(dir / "be.tif");
  EXPECT_EQ(source->info().dtype, DType::i32);
  EXPECT_TRUE(source->read_all() == expected);
  const Box box{{2, 4, 2}, {9, 8, 3}};  // rows 4..7 span strips 1 and 2
  EXPECT_TRUE(source->read_box(box) == expected.crop(box));
}

TEST(IoTiff, ReadsBigTiff) {
  TempDir dir;
  std::vector<PageSpec> pages{page_of(5, 5, 64, SAMPLEFORMAT_IEEEFP, 1), page_of(5, 5, 64, SAMPLEFORMAT_IEEEFP, 2)};
  write_pages(dir / "big.tif", pages, "w8");
  EXPECT_TRUE(io::read_volume(dir / "big.tif") == volume_of(pages, DType::f64));
}

TEST(IoTiff, SpacingFromImageDescription) {
  TempDir dir;
  PageSpec p = page_of(4, 4, 8, SAMPLEFORMAT_UINT, 1);
  p.description = R"({"spacing":[0.1,0.2,0.3],"by":"someone"})";
  write_pages(dir / "json.tif", {p, p});
  EXPECT_EQ(io::open_volume(dir / "json.tif")->info().spacing, (Spacing{0.1, 0.2, 0.3}));

  p.description = "ImageJ=1.54f\nimages=2\n";  // other software's text: default spacing
  write_pages(dir / "imagej.tif", {p, p});
  EXPECT_EQ(io::open_volume(dir / "imagej.tif")->info().spacing, Spacing{});

  p.description = R"({"spacing":[1,-2,3]})";
  write_pages(dir / "bad.tif", {p, p});
  expect_error([&] { io::open_volume(dir / "bad.tif"); }, {"bad.tif", "ImageDescription"});
}

// ---------------------------------------------------------------------------------------------
// Inconsistent or unsupported pages: the message names the file/page and the tag.

TEST(IoTiffErrors, PageWithDifferentWidth) {
  TempDir dir;
  write_pages(dir / "mixed.tif", {page_of(8, 6, 8, SAMPLEFORMAT_UINT, 1), page_of(8, 6, 8, SAMPLEFORMAT_UINT, 2),
                                  page_of(9, 6, 8, SAMPLEFORMAT_UINT, 3)});
  expect_error([&] { io::open_volume(dir / "mixed.tif"); }, {"mixed.tif", "page 2", "ImageWidth"});
}

TEST(IoTiffErrors, PageWithDifferentSampleFormat) {
  TempDir dir;
  write_pages(dir / "signs.tif", {page_of(8, 6, 16, SAMPLEFORMAT_UINT, 1), page_of(8, 6, 16, SAMPLEFORMAT_INT, 2)});
  expect_error([&] { io::open_volume(dir / "signs.tif"); }, {"signs.tif", "page 1", "SampleFormat"});
}

TEST(IoTiffErrors, FolderSliceWithDifferentBits) {
  TempDir dir;
  fs::create_directory(dir / "stack");
  for (int i = 0; i < 5; ++i)
    write_pages(dir / "stack" / ("slice_" + std::to_string(i) + ".tif"),
                {page_of(8, 6, i == 3 ? 16 : 8, SAMPLEFORMAT_UINT, std::uint64_t(i))});
  expect_error([&] { io::open_volume(dir / "stack"); }, {"slice_3.tif", "BitsPerSample"});
}

TEST(IoTiffErrors, FolderSliceWithSeveralPages) {
  TempDir dir;
  fs::create_directory(dir / "stack");
  write_pages(dir / "stack" / "a1.tif", {page_of(8, 6, 8, SAMPLEFORMAT_UINT, 1)});
  write_pages(dir / "stack" / "a2.tif", {page_of(8, 6, 8, SAMPLEFORMAT_UINT, 2), page_of(8, 6, 8, SAMPLEFORMAT_UINT, 3)});
  expect_error([&] { io::open_volume(dir / "stack"); }, {"a2.tif", "pages"});
}

TEST(IoTiffErrors, ChannelsNeedAChoiceAndUnsupportedSampleTypes) {
  TempDir dir;
  PageSpec rgb = page_of(8, 6, 8, SAMPLEFORMAT_UINT, 1);
  rgb.samples = 3;
  rgb.data = random_bytes(rgb.row_bytes() * rgb.height, 1);
  write_pages(dir / "rgb.tif", {rgb});
  expect_error([&] { io::open_volume(dir / "rgb.tif"); }, {"rgb.tif", "SamplesPerPixel", "choose one with --volume T (0..2)"});
  io::ReadOptions fourth;
  fourth.volume = 3;
  EXPECT_EQ(test::parameter_of([&] { io::open_volume(dir / "rgb.tif", fourth); }), "ReadOptions::volume");

  write_pages(dir / "u24.tif", {page_of(4, 4, 24, SAMPLEFORMAT_UINT, 1)});
  expect_error([&] { io::open_volume(dir / "u24.tif"); }, {"u24.tif", "BitsPerSample"});
}

// Sets the value of `tag` (a SHORT stored in its directory entry) in the first page of a
// little-endian classic TIFF, as a damaged or hand-written file would have it.
void patch_short_tag(const fs::path& path, std::uint16_t tag, std::uint16_t value) {
  auto bytes = test::io::read_bytes(path);
  ASSERT_EQ(char(bytes[0]), 'I');
  std::uint32_t ifd = 0;
  std::uint16_t entries = 0;
  std::memcpy(&ifd, bytes.data() + 4, 4);
  std::memcpy(&entries, bytes.data() + ifd, 2);
  for (std::uint16_t i = 0; i < entries; ++i) {
    std::byte* entry = bytes.data() + ifd + 2 + 12 * i;
    std::uint16_t id = 0;
    std::memcpy(&id, entry, 2);
    if (id != tag) continue;
    std::memcpy(entry + 8, &value, 2);
    test::io::write_bytes(path, bytes);
    return;
  }
  FAIL() << "no tag " << tag << " in " << path;
}

TEST(IoTiffErrors, ImpossibleChannelLayoutsAreNamed) {
  TempDir dir;
  PageSpec page = page_of(8, 6, 8, SAMPLEFORMAT_UINT, 1);
  write_pages(dir / "planar.tif", {page});
  patch_short_tag(dir / "planar.tif", TIFFTAG_PLANARCONFIG, 3);
  expect_error([&] { io::open_volume(dir / "planar.tif"); }, {"planar.tif", "PlanarConfiguration"});
  write_pages(dir / "none.tif", {page});
  patch_short_tag(dir / "none.tif", TIFFTAG_SAMPLESPERPIXEL, 0);
  expect_error([&] { io::open_volume(dir / "none.tif"); }, {"none.tif", "SamplesPerPixel"});
}

// Multi-channel microscopy: every channel of chunky strips, chunky tiles and planar strips reads
// as a volume of its own, whole and in boxes.
TEST(IoTiff, EveryChannelReadsAsAVolume) {
  TempDir dir;
  struct Layout {
    const char* name;
    std::uint16_t bits, samples;
    std::uint32_t tile, rows_per_strip;
    bool planar;
  };
  for (const Layout& l : {Layout{"chunky.tif", 8, 3, 0, 2, false}, Layout{"tiles.tif", 16, 2, 16, 0, false},
                          Layout{"planar.tif", 16, 4, 0, 3, true}}) {
    std::vector<PageSpec> pages;
    for (std::uint64_t z = 0; z < 3; ++z) {
      PageSpec p = page_of(20, 18, l.bits, SAMPLEFORMAT_UINT, 10 + z);
      p.samples = l.samples;
      p.tile = l.tile;
      p.rows_per_strip = l.rows_per_strip;
      p.planar = l.planar;
      p.data = random_bytes(p.row_bytes() * p.height, 20 + z);
      pages.push_back(p);
    }
    write_pages(dir / l.name, pages);
    const std::size_t sample = l.bits / 8;
    for (std::uint16_t c = 0; c < l.samples; ++c) {
      io::ReadOptions o;
      o.volume = c;
      auto source = io::open_volume(dir / l.name, o);
      EXPECT_EQ(source->info().volumes, l.samples) << l.name;
      Volume expected({20, 18, 3}, l.bits == 8 ? DType::u8 : DType::u16);
      for (std::size_t z = 0; z < 3; ++z)
        for (std::size_t i = 0; i < 20 * 18; ++i) {
          const std::size_t from = l.planar ? (c * 20 * 18 + i) * sample : (i * l.samples + c) * sample;
          std::memcpy(expected.bytes() + (z * 20 * 18 + i) * sample, pages[z].data.data() + from, sample);
        }
      EXPECT_TRUE(source->read_all() == expected) << l.name << " channel " << c;
      const Box box{{3, 5, 1}, {19, 17, 3}};
      EXPECT_TRUE(source->read_box(box) == expected.crop(box)) << l.name << " channel " << c;
    }
  }
}

TEST(IoTiffErrors, NotATiffAndEmptyFolder) {
  TempDir dir;
  std::ofstream(dir / "fake.tif") << "this is not a TIFF file at all";
  expect_error([&] { io::open_volume(dir / "fake.tif"); }, {"fake.tif"});
  fs::create_directory(dir / "empty");
  expect_error([&] { io::open_volume(dir / "empty"); }, {"empty", "slices"});
}

// ---------------------------------------------------------------------------------------------
// Streaming: a request opens only the pages it covers, so a damaged page outside it is not
// touched, and a damaged page inside it is reported by name.

TEST(IoTiffStreaming, FolderReadsOnlyRequestedSlices) {
  TempDir dir;
  const io::WriteOptions options{.format = "tiff"};
  const Volume v = random_volume({6, 5, 6}, DType::u16, 8);
  io::write_volume(dir / "stack", v, options);
  auto source = io::open_volume(dir / "stack");
  std::ofstream(dir / "stack" / "slice_0005.tif", std::ios::trunc) << "damaged after open";
  EXPECT_TRUE(source->read_slab(0, 5) == v.crop({{0, 0, 0}, {6, 5, 5}}));
  expect_error([&] { source->read_slab(3, 6); }, {"slice_0005.tif"});
}

TEST(IoTiffStreaming, MultiPageReadsOnlyRequestedPages) {
  TempDir dir;
  std::vector<PageSpec> pages;
  for (std::uint64_t z = 0; z < 5; ++z) {
    PageSpec p = page_of(16, 16, 8, SAMPLEFORMAT_UINT, z);
    p.compression = COMPRESSION_ADOBE_DEFLATE;
    pages.push_back(p);
  }
  write_pages(dir / "stack.tif", pages);
  // Overwrite page 3's compressed strip with bytes that are not a Deflate stream.
  std::uint64_t* offsets = nullptr;
  std::uint64_t* counts = nullptr;
  TIFF* tif = TIFFOpen((dir / "stack.tif").c_str(), "r");
  ASSERT_NE(tif, nullptr);
  ASSERT_EQ(TIFFSetDirectory(tif, 3), 1);
  ASSERT_EQ(TIFFGetField(tif, TIFFTAG_STRIPOFFSETS, &offsets), 1);
  ASSERT_EQ(TIFFGetField(tif, TIFFTAG_STRIPBYTECOUNTS, &counts), 1);
  const std::uint64_t offset = offsets[0], count = counts[0];
  TIFFClose(tif);
  {
    std::fstream f(dir / "stack.tif", std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(std::streamoff(offset));
    const std::string junk(count, '\xff');
    f.write(junk.data(), std::streamsize(count));
  }
  auto source = io::open_volume(dir / "stack.tif");
  const Volume expected = volume_of(pages, DType::u8);
  EXPECT_TRUE(source->read_slab(0, 3) == expected.crop({{0, 0, 0}, {16, 16, 3}}));
  EXPECT_TRUE(source->read_slab(4, 5) == expected.crop({{0, 0, 4}, {16, 16, 5}}));
  expect_error([&] { source->read_slab(2, 4); }, {"stack.tif", "page 3"});
}

}  // namespace
}  // namespace strata
