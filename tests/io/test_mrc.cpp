// MRC volumes: what the writer stores reads back (samples, voxel size, statistics in the
// header), files of the other byte order with an extended header read by the header's
// fields, and the modes and layouts that are not read are refused naming the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <vector>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

std::vector<char> file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A 1024-byte MRC2014 header in `order`, axes 1 2 3, the signature and machine stamp set.
std::vector<char> header(std::endian order, std::array<std::int32_t, 3> n, std::int32_t mode,
                         std::array<std::int32_t, 3> sampling, std::array<float, 3> cell, std::int32_t extended) {
  std::vector<std::byte> h(1024);
  const auto put = [&](std::size_t at, auto v) {
    auto bits = std::bit_cast<std::array<std::byte, sizeof(v)>>(v);
    if (order != std::endian::native) std::reverse(bits.begin(), bits.end());
    std::memcpy(h.data() + at, bits.data(), bits.size());
  };
  for (std::size_t a = 0; a < 3; ++a) {
    put(4 * a, n[a]);
    put(28 + 4 * a, sampling[a]);
    put(40 + 4 * a, cell[a]);
    put(64 + 4 * a, std::int32_t(a + 1));
  }
  put(12, mode);
  put(92, extended);
  std::memcpy(h.data() + 208, "MAP ", 4);
  h[212] = h[213] = std::byte(order == std::endian::big ? 0x11 : 0x44);
  std::vector<char> out(h.size());
  std::memcpy(out.data(), h.data(), h.size());
  return out;
}

void write_file(const fs::path& path, const std::vector<char>& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

float header_float(const std::vector<char>& bytes, std::size_t at) {
  float v;
  std::memcpy(&v, bytes.data() + at, sizeof v);
  return v;
}

TEST(IoMrc, WrittenVolumesReadBackWithTheirVoxelSizeAndStatistics) {
  TempDir dir;
  Volume v(Extent{5, 4, 3}, DType::i16, Spacing{0.5, 0.75, 2.0});
  auto samples = v.samples<std::int16_t>();
  for (std::size_t i = 0; i < samples.size(); ++i) samples[i] = std::int16_t(int(i) * 37 % 200 - 90);
  write_volume(dir / "v.mrc", v);
  EXPECT_EQ(detect_format(dir / "v.mrc").name, "mrc");

  const Volume back = read_volume(dir / "v.mrc");
  ASSERT_EQ(back.dims(), v.dims());
  ASSERT_EQ(back.dtype(), DType::i16);
  EXPECT_EQ(std::memcmp(back.bytes(), v.bytes(), v.byte_size()), 0);
  EXPECT_DOUBLE_EQ(back.spacing().x, 0.5);
  EXPECT_DOUBLE_EQ(back.spacing().y, 0.75);
  EXPECT_DOUBLE_EQ(back.spacing().z, 2.0);

  // dmin, dmax, dmean in the header are the samples' own.
  const std::vector<char> bytes = file_bytes(dir / "v.mrc");
  ASSERT_EQ(bytes.size(), 1024 + v.byte_size());
  double lo = 1e9, hi = -1e9, sum = 0;
  for (std::int16_t s : samples) {
    lo = std::min<double>(lo, s);
    hi = std::max<double>(hi, s);
    sum += s;
  }
  EXPECT_EQ(header_float(bytes, 76), float(lo));
  EXPECT_EQ(header_float(bytes, 80), float(hi));
  EXPECT_FLOAT_EQ(header_float(bytes, 84), float(sum / double(samples.size())));
  EXPECT_EQ(std::memcmp(bytes.data() + 208, "MAP ", 4), 0);
}

TEST(IoMrc, BigEndianFilesWithAnExtendedHeaderReadByTheirFields) {
  TempDir dir;
  // 3x2x2 float32, big-endian, a 100-byte extended header, a cell of 6 x 4 x 2 Å sampled 3 x 2 x 1.
  std::vector<char> bytes = header(std::endian::big, {3, 2, 2}, 2, {3, 2, 1}, {6.0f, 4.0f, 2.0f}, 100);
  bytes.resize(bytes.size() + 100, 'x');
  std::vector<float> values(12);
  for (std::size_t i = 0; i < values.size(); ++i) {
    values[i] = 0.25f * float(i) - 1.0f;
    auto b = std::bit_cast<std::array<char, 4>>(values[i]);
    std::reverse(b.begin(), b.end());
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  write_file(dir / "tomo.rec", bytes);
  const Volume v = read_volume(dir / "tomo.rec");
  ASSERT_EQ(v.dims(), (Extent{3, 2, 2}));
  ASSERT_EQ(v.dtype(), DType::f32);
  const auto got = v.samples<float>();
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(got[i], values[i]) << i;
  EXPECT_DOUBLE_EQ(v.spacing().x, 2.0);
  EXPECT_DOUBLE_EQ(v.spacing().y, 2.0);
  EXPECT_DOUBLE_EQ(v.spacing().z, 2.0);
  // The same bytes under another name are recognised by their signature.
  write_file(dir / "tomo.dat", bytes);
  EXPECT_EQ(detect_format(dir / "tomo.dat").name, "mrc");
}

// Runs `f`, expects a FormatError whose text holds `field` and `hint`.
template <class F>
void expect_refused(F&& f, const std::string& field, const std::string& hint) {
  try {
    f();
    ADD_FAILURE() << "accepted";
  } catch (const FormatError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(field), std::string::npos) << what;
    EXPECT_NE(what.find(hint), std::string::npos) << what;
  }
}

// Mode 12: every kind of half (normal, subnormal, signed zero, the largest, infinity, NaN)
// becomes the float32 of the same value, in either byte order.
TEST(IoMrc, Float16SamplesReadAsTheirFloat32Values) {
  TempDir dir;
  const std::array<std::uint16_t, 8> halves{0x3C00, 0xC000, 0x0001, 0x7C00, 0x3555, 0x7BFF, 0x8000, 0x7E00};
  const std::array<float, 7> expected{1.0f, -2.0f, 0x1p-24f, INFINITY, 0.333251953125f, 65504.0f, -0.0f};
  for (const std::endian order : {std::endian::little, std::endian::big}) {
    std::vector<char> bytes = header(order, {2, 2, 2}, 12, {2, 2, 2}, {4, 4, 4}, 0);
    for (std::uint16_t h : halves) {
      const char lo = char(h & 0xFF), hi = char(h >> 8);
      bytes.push_back(order == std::endian::little ? lo : hi);
      bytes.push_back(order == std::endian::little ? hi : lo);
    }
    write_file(dir / "half.mrc", bytes);
    const Volume v = read_volume(dir / "half.mrc");
    ASSERT_EQ(v.dtype(), DType::f32);
    const auto got = v.samples<float>();
    for (std::size_t i = 0; i < expected.size(); ++i) {
      EXPECT_EQ(got[i], expected[i]) << i;
      EXPECT_EQ(std::signbit(got[i]), std::signbit(expected[i])) << i;
    }
    EXPECT_TRUE(std::isnan(got[7]));
    EXPECT_DOUBLE_EQ(v.spacing().x, 2.0);
    // A box inside the volume reads the same values as the whole.
    const Volume corner = open_volume(dir / "half.mrc")->read_box({{1, 1, 1}, {2, 2, 2}});
    EXPECT_TRUE(std::isnan(corner.samples<float>()[0]));
    EXPECT_EQ(open_volume(dir / "half.mrc")->read_box({{1, 0, 0}, {2, 1, 1}}).samples<float>()[0], -2.0f);
  }
}

TEST(IoMrc, ModesAndLayoutsThatAreNotReadAreRefusedNamingTheField) {
  TempDir dir;
  const auto body = [](std::size_t n) { return std::vector<char>(n, 0); };
  std::vector<char> complex = header(std::endian::little, {2, 2, 2}, 4, {2, 2, 2}, {2, 2, 2}, 0);
  write_file(dir / "complex.mrc", complex);
  expect_refused([&] { (void)open_volume(dir / "complex.mrc"); }, "mode", "complex");

  std::vector<char> swapped = header(std::endian::little, {2, 2, 2}, 1, {2, 2, 2}, {2, 2, 2}, 0);
  const std::int32_t two = 2, one = 1;
  std::memcpy(swapped.data() + 64, &two, 4);
  std::memcpy(swapped.data() + 68, &one, 4);
  const std::vector<char> body16 = body(16);
  swapped.insert(swapped.end(), body16.begin(), body16.end());
  write_file(dir / "swapped.mrc", swapped);
  expect_refused([&] { (void)open_volume(dir / "swapped.mrc"); }, "mapc, mapr, maps", "2 1 3");

  std::vector<char> truncated = header(std::endian::little, {4, 4, 4}, 2, {4, 4, 4}, {4, 4, 4}, 0);
  const std::vector<char> body10 = body(10);
  truncated.insert(truncated.end(), body10.begin(), body10.end());
  write_file(dir / "short.mrc", truncated);
  expect_refused([&] { (void)open_volume(dir / "short.mrc"); }, "size", "expected 1280 bytes");

  // Dims whose product overflows are a damaged header, named as such.
  write_file(dir / "huge.mrc", header(std::endian::little, {1 << 30, 1 << 30, 1 << 30}, 2, {1, 1, 1}, {1, 1, 1}, 0));
  expect_refused([&] { (void)open_volume(dir / "huge.mrc"); }, "nx, ny, nz", "do not fit");
  write_file(dir / "big.mrc", header(std::endian::little, {1 << 20, 1 << 20, 1 << 20}, 2, {1, 1, 1}, {1, 1, 1}, 0));
  expect_refused([&] { (void)open_volume(dir / "big.mrc"); }, "size", "expected");

  write_file(dir / "tiny.mrc", body(100));
  EXPECT_THROW((void)open_volume(dir / "tiny.mrc"), FormatError);
}

TEST(IoMrc, UnsignedBytesAreWidenedToMode6AndOtherTypesRefused) {
  TempDir dir;
  const VolumeFormat* mrc = find_format("mrc");
  ASSERT_NE(mrc, nullptr);
  EXPECT_TRUE(mrc->writes(DType::u8));
  EXPECT_FALSE(mrc->writes(DType::f64));
  Volume bytes(Extent{3, 2, 2}, DType::u8);
  auto b = bytes.samples<std::uint8_t>();
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = std::uint8_t(250 - 20 * i);
  write_volume(dir / "em.mrc", bytes);
  const Volume back = read_volume(dir / "em.mrc");
  ASSERT_EQ(back.dtype(), DType::u16);  // MRC2014's mode 0 is signed: bytes go to mode 6
  const auto w = back.samples<std::uint16_t>();
  for (std::size_t i = 0; i < b.size(); ++i) EXPECT_EQ(w[i], b[i]) << i;
  EXPECT_THROW(write_volume(dir / "x.mrc", Volume(Extent{2, 2, 2}, DType::u32)), Error);
  EXPECT_FALSE(fs::exists(dir / "x.mrc"));
}

}  // namespace
}  // namespace strata::io
