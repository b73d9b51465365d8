// Raw volumes: dims/dtype from options or a JSON sidecar, exact size checks, byte order.
#include <gtest/gtest.h>

#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

using namespace strata::test::io;

TEST(IoRaw, RoundTripIsBitExactForEveryDtype) {
  test::TempDir dir;
  for (DType t : kAllDtypes) {
    SCOPED_TRACE(std::string(dtype_name(t)));
    Volume original = random_bytes_volume({7, 5, 3}, t, 11);
    auto path = dir / ("v_" + std::string(dtype_name(t)) + ".raw");
    write_volume(path, original);
    EXPECT_EQ(std::filesystem::file_size(path), original.byte_size());  // no header, just samples
    expect_same(read_volume(path), original);
  }
}

TEST(IoRaw, WriterCreatesSidecarWithDimsDtypeAndSpacing) {
  test::TempDir dir;
  write_volume(dir / "a.raw", random_bytes_volume({4, 3, 2}, DType::i16, 1));
  const std::string sidecar = read_text(dir / "a.raw.json");
  EXPECT_NE(sidecar.find("\"dims\""), std::string::npos);
  EXPECT_NE(sidecar.find("\"i16\""), std::string::npos);
  EXPECT_NE(sidecar.find("1.25"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "a.raw.tmp"));
  EXPECT_FALSE(std::filesystem::exists(dir / "a.raw.json.tmp"));
}

TEST(IoRaw, SlabsWrittenInPiecesEqualTheWholeVolume) {
  test::TempDir dir;
  Volume original = random_bytes_volume({6, 4, 7}, DType::u32, 5);
  auto writer = create_volume_writer(dir / "s.raw", original.info());
  writer->write_slab(original.crop({{0, 0, 0}, {6, 4, 3}}));
  writer->write_slab(original.crop({{0, 0, 3}, {6, 4, 4}}));
  writer->write_slab(original.crop({{0, 0, 4}, {6, 4, 7}}));
  writer->finish();
  EXPECT_TRUE(read_volume(dir / "s.raw") == original);
}

TEST(IoRaw, OptionsDescribeAFileWithoutSidecar) {
  test::TempDir dir;
  const std::uint16_t samples[] = {1, 2, 3, 4, 5, 6, 700, 800, 900, 1000, 1100, 1200};
  write_bytes(dir / "plain.bin", samples, sizeof samples);
  ReadOptions options;
  options.raw_dims = Extent{3, 2, 2};
  options.raw_dtype = DType::u16;
  options.raw_spacing = Spacing{2, 3, 4};
  Volume v = read_volume(dir / "plain.bin", options);
  EXPECT_EQ(v.dims(), (Extent{3, 2, 2}));
  EXPECT_EQ(v.spacing(), (Spacing{2, 3, 4}));
  EXPECT_EQ(v.value(0, 0, 0), 1);
  EXPECT_EQ(v.value(2, 1, 0), 6);
  EXPECT_EQ(v.value(0, 0, 1), 700);
  EXPECT_EQ(v.value(2, 1, 1), 1200);
}

TEST(IoRaw, StemSidecarBesideTheFileIsFound) {
  test::TempDir dir;
  const std::int16_t samples[] = {-1, 2, -3, 4, -5, 6};
  write_bytes(dir / "scan.raw", samples, sizeof samples);
  write_text(dir / "scan.json", R"({"dims":[1,2,3],"dtype":"i16","spacing":[0.5,0.5,2]})");
  Volume v = read_volume(dir / "scan.raw");
  EXPECT_EQ(v.dims(), (Extent{1, 2, 3}));
  EXPECT_EQ(v.dtype(), DType::i16);
  EXPECT_EQ(v.spacing(), (Spacing{0.5, 0.5, 2}));
  EXPECT_EQ(v.value(0, 0, 0), -1);
  EXPECT_EQ(v.value(0, 1, 2), 6);
}

TEST(IoRaw, OptionsOverrideSidecarFieldByField) {
  test::TempDir dir;
  const std::uint8_t samples[8] = {0, 1, 2, 3, 4, 5, 6, 7};
  write_bytes(dir / "o.raw", samples, sizeof samples);
  write_text(dir / "o.raw.json", R"({"dims":[2,2,2],"dtype":"u16"})");
  ReadOptions options;
  options.raw_dtype = DType::u8;  // the sidecar's dims stay, its dtype is overridden
  Volume v = read_volume(dir / "o.raw", options);
  EXPECT_EQ(v.dims(), (Extent{2, 2, 2}));
  EXPECT_EQ(v.dtype(), DType::u8);
  EXPECT_EQ(v.value(1, 1, 1), 7);
}

TEST(IoRaw, BigEndianAndHeaderBytesOptions) {
  test::TempDir dir;
  // 3-byte header, then u16 samples 0x0102 and 0xA0B0 stored big endian.
  const unsigned char bytes[] = {9, 9, 9, 0x01, 0x02, 0xA0, 0xB0};
  write_bytes(dir / "be.raw", bytes, sizeof bytes);
  ReadOptions options;
  options.raw_dims = Extent{2, 1, 1};
  options.raw_dtype = DType::u16;
  options.raw_big_endian = true;
  options.raw_header_bytes = 3;
  Volume v = read_volume(dir / "be.raw", options);
  EXPECT_EQ(v.value(0, 0, 0), 0x0102);
  EXPECT_EQ(v.value(1, 0, 0), 0xA0B0);
}

TEST(IoRaw, SidecarMayDeclareBigEndian) {
  test::TempDir dir;
  const unsigned char bytes[] = {0x3f, 0x80, 0x00, 0x00, 0xc0, 0x00, 0x00, 0x00};  // 1.0f, -2.0f big endian
  write_bytes(dir / "f.raw", bytes, sizeof bytes);
  write_text(dir / "f.raw.json", R"({"dims":[2,1,1],"dtype":"f32","endian":"big"})");
  Volume v = read_volume(dir / "f.raw");
  EXPECT_EQ(v.value(0, 0, 0), 1.0);
  EXPECT_EQ(v.value(1, 0, 0), -2.0);
}

TEST(IoRaw, ReadBoxOfSubBoxEqualsCropOfWhole) {
  test::TempDir dir;
  Volume original = random_bytes_volume({9, 8, 7}, DType::f64, 3);
  write_volume(dir / "b.raw", original);
  auto source = open_volume(dir / "b.raw");
  for (Box box : {Box{{1, 2, 3}, {8, 5, 6}}, Box{{0, 1, 2}, {9, 7, 4}}, Box{{4, 0, 0}, {5, 8, 7}},
                  Box{{8, 7, 6}, {9, 8, 7}}}) {
    SCOPED_TRACE(box.to_string());
    Volume part = source->read_box(box);
    EXPECT_TRUE(part == original.crop(box));
    EXPECT_EQ(part.spacing(), original.spacing());
  }
  EXPECT_TRUE(source->read_slab(2, 5) == original.crop({{0, 0, 2}, {9, 8, 5}}));
}

TEST(IoRaw, WrongFileSizeNamesExpectedAndFoundBytes) {
  test::TempDir dir;
  std::string bytes(47, 'x');
  write_text(dir / "short.raw", bytes);
  ReadOptions options;
  options.raw_dims = Extent{4, 3, 2};
  options.raw_dtype = DType::u16;
  try {
    open_volume(dir / "short.raw", options);
    FAIL() << "a 47-byte file cannot hold 4x3x2 u16";
  } catch (const FormatError& e) {
    const std::string expected = (dir / "short.raw").string() + ": size: expected 48 bytes for 4x3x2 u16, found 47";
    EXPECT_EQ(std::string(e.what()), expected);
  }
  write_text(dir / "long.raw", std::string(49, 'x'));  // extra bytes are as wrong as missing ones
  EXPECT_THROW(open_volume(dir / "long.raw", options), FormatError);
}

}  // namespace
}  // namespace strata::io
