// NIfTI-1 and NIfTI-2 reading and writing: round trips for every writable dtype (.nii and
// .nii.gz), the headers we write, scl_slope/scl_inter, big-endian files, files of several
// volumes, corrupt inputs, real atlases and nibabel's NIfTI-2 example.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <set>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata {
namespace {

namespace fs = std::filesystem;
using test::TempDir;
using namespace test::io;

// A NIfTI-1 header written field by field, independently of the writer under test, in either
// byte order. Defaults: a 4x3x2 volume of `datatype`, data at 352.
struct HandHeader {
  std::int32_t sizeof_hdr = 348;
  std::array<std::int16_t, 8> dim{3, 4, 3, 2, 1, 1, 1, 1};
  std::int16_t datatype = 4;  // i16
  std::int16_t bitpix = 16;
  std::array<float, 8> pixdim{1, 0.75f, 1.5f, 3.0f, 1, 1, 1, 1};
  float vox_offset = 352;
  float scl_slope = 0, scl_inter = 0;
  std::array<char, 4> magic{'n', '+', '1', '\0'};
  bool big_endian = false;

  template <class T>
  void put(std::vector<std::byte>& b, std::size_t offset, T value) const {
    std::memcpy(b.data() + offset, &value, sizeof(T));
    if (big_endian) std::reverse(b.begin() + std::ptrdiff_t(offset), b.begin() + std::ptrdiff_t(offset + sizeof(T)));
  }

  std::vector<std::byte> bytes() const {
    std::vector<std::byte> b(352);
    put(b, 0, sizeof_hdr);
    for (std::size_t i = 0; i < 8; ++i) put(b, 40 + 2 * i, dim[i]);
    put(b, 70, datatype);
    put(b, 72, bitpix);
    for (std::size_t i = 0; i < 8; ++i) put(b, 76 + 4 * i, pixdim[i]);
    put(b, 108, vox_offset);
    put(b, 112, scl_slope);
    put(b, 116, scl_inter);
    std::memcpy(b.data() + 344, magic.data(), 4);
    return b;
  }
};

// Appends samples to a header in the header's byte order.
template <class T>
std::vector<std::byte> with_samples(const HandHeader& h, const std::vector<T>& samples) {
  std::vector<std::byte> b = h.bytes();
  for (T v : samples) {
    std::byte raw[sizeof(T)];
    std::memcpy(raw, &v, sizeof(T));
    if (h.big_endian) std::reverse(raw, raw + sizeof(T));
    b.insert(b.end(), raw, raw + sizeof(T));
  }
  return b;
}

std::vector<std::int16_t> ramp_i16(std::size_t n) {
  std::vector<std::int16_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = std::int16_t(int(i) * 37 - 300);
  return v;
}

// `v` holds exactly `expected`, as samples of type T.
template <class T>
void expect_samples(const Volume& v, const std::vector<T>& expected) {
  const auto s = v.samples<T>();
  ASSERT_EQ(s.size(), expected.size());
  EXPECT_TRUE(std::equal(s.begin(), s.end(), expected.begin()));
}

// `v` is what a default HandHeader file holds: 4x3x2 voxels of 0.75x1.5x3, here `expected` as `dtype`.
template <class T>
void expect_hand_volume(const Volume& v, DType dtype, const std::vector<T>& expected) {
  ASSERT_EQ(v.dtype(), dtype);
  EXPECT_EQ(v.dims(), (Extent{4, 3, 2}));
  EXPECT_EQ(v.spacing(), (Spacing{0.75, 1.5, 3.0}));
  expect_samples(v, expected);
}

// ---------------------------------------------------------------------------------------------

class IoNiftiRoundTrip : public ::testing::TestWithParam<std::tuple<DType, const char*>> {};

TEST_P(IoNiftiRoundTrip, IsBitExactWithSpacingAndBoxes) {
  const auto [dtype, suffix] = GetParam();
  TempDir dir;
  const fs::path path = dir / (std::string("v") + suffix);
  const Volume original = random_volume({7, 5, 6}, dtype, 42);
  {
    // Two slabs, as a streaming conversion would write them.
    auto writer = io::create_volume_writer(path, original.info());
    writer->write_slab(original.crop({{0, 0, 0}, {7, 5, 2}}));
    writer->write_slab(original.crop({{0, 0, 2}, {7, 5, 6}}));
    writer->finish();
  }
  expect_same(io::read_volume(path), original);
  const Box box{{1, 2, 3}, {6, 4, 5}};
  EXPECT_TRUE(io::open_volume(path)->read_box(box) == original.crop(box));
}

INSTANTIATE_TEST_SUITE_P(AllWritableTypes, IoNiftiRoundTrip,
                         ::testing::Combine(::testing::Values(DType::u8, DType::u16, DType::i16, DType::u32, DType::i32,
                                                              DType::f32, DType::f64),
                                            ::testing::Values(".nii", ".nii.gz")),
                         [](const auto& info) {
                           return std::string(dtype_name(std::get<0>(info.param))) +
                                  (std::string(std::get<1>(info.param)) == ".nii" ? "_nii" : "_nii_gz");
                         });

TEST(IoNifti, WrittenHeaderFollowsTheNifti1Layout) {
  TempDir dir;
  const Volume v = random_volume({7, 5, 3}, DType::u16, 3, {0.5, 1.25, 2.0});
  io::write_volume(dir / "v.nii", v);
  const auto bytes = read_bytes(dir / "v.nii");
  ASSERT_EQ(bytes.size(), 352 + v.byte_size());
  auto get = [&](std::size_t offset, auto value) {
    std::memcpy(&value, bytes.data() + offset, sizeof(value));
    return value;
  };
  EXPECT_EQ(get(0, std::int32_t{}), 348);
  EXPECT_EQ(std::memcmp(bytes.data() + 344, "n+1\0", 4), 0);
  EXPECT_EQ(get(108, float{}), 352.0f);
  EXPECT_EQ(get(40, std::int16_t{}), 3);
  EXPECT_EQ(get(42, std::int16_t{}), 7);
  EXPECT_EQ(get(44, std::int16_t{}), 5);
  EXPECT_EQ(get(46, std::int16_t{}), 3);
  EXPECT_EQ(get(70, std::int16_t{}), 512);  // DT_UINT16
  EXPECT_EQ(get(72, std::int16_t{}), 16);
  EXPECT_EQ(get(80, float{}), 0.5f);
  EXPECT_EQ(get(84, float{}), 1.25f);
  EXPECT_EQ(get(88, float{}), 2.0f);
  EXPECT_EQ(get(112, float{}), 0.0f);         // scl_slope: no scaling
  EXPECT_EQ(get(252, std::int16_t{}), 0);     // qform_code
  EXPECT_EQ(get(254, std::int16_t{}), 0);     // sform_code
  EXPECT_EQ(std::memcmp(bytes.data() + 352, v.bytes(), v.byte_size()), 0);
}

TEST(IoNifti, GzOutputIsTheSameFileGzipped) {
  TempDir dir;
  const Volume v = random_volume({6, 4, 3}, DType::f32, 5);
  io::write_volume(dir / "v.nii", v);
  io::write_volume(dir / "v.nii.gz", v);
  const auto plain = read_bytes(dir / "v.nii");
  const auto gz = read_bytes(dir / "v.nii.gz");
  ASSERT_TRUE(io::detail::looks_gzipped(gz.data(), gz.size()));
  EXPECT_EQ(io::detail::gunzip_to_memory(gz.data(), gz.size(), "v.nii.gz", "gzip"), plain);
}

TEST(IoNifti, WriterRejectsI8) {
  TempDir dir;
  // The format's own writer refuses too, not only create_volume_writer's check of write_dtypes.
  const io::VolumeFormat nifti = io::detail::nifti_format();
  EXPECT_FALSE(nifti.writes(DType::i8));
  EXPECT_THROW(nifti.create_writer(dir / "v.nii", VolumeInfo{{2, 2, 2}, DType::i8, {}}, {}), Error);
  EXPECT_FALSE(fs::exists(dir / "v.nii.tmp"));
}

TEST(IoNifti, ReadsI8) {
  TempDir dir;
  HandHeader h;
  h.datatype = 256;
  h.bitpix = 8;
  std::vector<std::int8_t> samples(24);
  for (std::size_t i = 0; i < samples.size(); ++i) samples[i] = std::int8_t(int(i) * 11 - 128);
  write_bytes(dir / "i8.nii", with_samples(h, samples));
  expect_hand_volume(io::read_volume(dir / "i8.nii"), DType::i8, samples);
}

TEST(IoNifti, SlopeAndInterceptGiveF32) {
  TempDir dir;
  HandHeader h;
  h.scl_slope = 2;
  h.scl_inter = 1;
  const auto stored = ramp_i16(24);
  write_bytes(dir / "scaled.nii", with_samples(h, stored));
  auto source = io::open_volume(dir / "scaled.nii");
  EXPECT_EQ(source->info().dtype, DType::f32);
  const Volume v = source->read_all();
  ASSERT_EQ(v.dtype(), DType::f32);
  auto s = v.samples<float>();
  for (std::size_t i = 0; i < stored.size(); ++i) EXPECT_EQ(s[i], 2.0f * stored[i] + 1.0f) << i;
  // A box is scaled too: voxel (1,2,1) is index 1 + 2*4 + 1*12 = 21.
  const Volume box = source->read_box({{1, 2, 1}, {2, 3, 2}});
  EXPECT_EQ(box.samples<float>()[0], 2.0f * stored[21] + 1.0f);
}

TEST(IoNifti, SlopeAppliedToGzippedInput) {
  TempDir dir;
  HandHeader h;
  h.datatype = 2;
  h.bitpix = 8;
  h.scl_slope = 0.5f;
  h.scl_inter = -10;
  std::vector<std::uint8_t> stored(24);
  for (std::size_t i = 0; i < stored.size(); ++i) stored[i] = std::uint8_t(i * 10);
  const auto gz = with_samples(h, stored);
  write_gzipped(dir / "scaled.nii.gz", gz.data(), gz.size());
  const Volume v = io::read_volume(dir / "scaled.nii.gz");
  ASSERT_EQ(v.dtype(), DType::f32);
  for (std::size_t i = 0; i < stored.size(); ++i) EXPECT_EQ(v.samples<float>()[i], 0.5f * stored[i] - 10.0f);
}

TEST(IoNifti, IdentityOrZeroSlopeKeepsTheStoredType) {
  TempDir dir;
  const auto stored = ramp_i16(24);
  for (auto [slope, inter] : {std::pair{1.0f, 0.0f}, std::pair{0.0f, 5.0f}}) {
    HandHeader h;
    h.scl_slope = slope;
    h.scl_inter = inter;
    write_bytes(dir / "plain.nii", with_samples(h, stored));
    const Volume v = io::read_volume(dir / "plain.nii");
    ASSERT_EQ(v.dtype(), DType::i16) << "slope " << slope << " inter " << inter;
    expect_samples(v, stored);
  }
}

TEST(IoNifti, SlopeOnF64StaysF64) {
  TempDir dir;
  HandHeader h;
  h.datatype = 64;
  h.bitpix = 64;
  h.scl_slope = 0.5f;
  h.scl_inter = -3;
  std::vector<double> stored(24);
  for (std::size_t i = 0; i < stored.size(); ++i) stored[i] = 1e10 + double(i) * 0.25;
  write_bytes(dir / "f64.nii", with_samples(h, stored));
  const Volume v = io::read_volume(dir / "f64.nii");
  ASSERT_EQ(v.dtype(), DType::f64);
  for (std::size_t i = 0; i < stored.size(); ++i) EXPECT_EQ(v.samples<double>()[i], stored[i] * 0.5 - 3.0);
}

TEST(IoNifti, ReadsBigEndianFiles) {
  TempDir dir;
  HandHeader h;
  h.big_endian = true;
  const auto stored = ramp_i16(24);
  write_bytes(dir / "be16.nii", with_samples(h, stored));
  expect_hand_volume(io::read_volume(dir / "be16.nii"), DType::i16, stored);

  h.datatype = 16;
  h.bitpix = 32;
  h.scl_slope = 3;  // scaling read big endian too
  std::vector<float> floats(24);
  for (std::size_t i = 0; i < floats.size(); ++i) floats[i] = float(i) * -1.5f + 0.125f;
  write_bytes(dir / "be32.nii", with_samples(h, floats));
  const Volume f = io::read_volume(dir / "be32.nii");
  ASSERT_EQ(f.dtype(), DType::f32);
  for (std::size_t i = 0; i < floats.size(); ++i) EXPECT_EQ(f.samples<float>()[i], floats[i] * 3.0f);
}

TEST(IoNifti, DimZeroMayBeFourWithOneVolumeOrChooseOne) {
  TempDir dir;
  HandHeader h;
  h.dim = {4, 4, 3, 2, 1, 1, 1, 1};
  write_bytes(dir / "4d.nii", with_samples(h, ramp_i16(24)));
  EXPECT_EQ(io::open_volume(dir / "4d.nii")->info().dims, (Extent{4, 3, 2}));

  h.dim = {4, 4, 3, 2, 2, 1, 1, 1};
  write_bytes(dir / "4d2.nii", with_samples(h, ramp_i16(48)));
  expect_error([&] { io::open_volume(dir / "4d2.nii"); }, {"4d2.nii", "dim", "2 volumes", "--volume"});

  h.dim = {2, 4, 3, 1, 1, 1, 1, 1};
  write_bytes(dir / "2d.nii", with_samples(h, ramp_i16(12)));
  expect_error([&] { io::open_volume(dir / "2d.nii"); }, {"2d.nii", "dim[0]"});
}

// Several volumes (dim[4..7]) follow each other; ReadOptions::volume picks one, and every
// command's --volume maps to it.
TEST(IoNifti, ReadsTheChosenVolumeOfSeveral) {
  TempDir dir;
  HandHeader h;
  h.dim = {5, 4, 3, 2, 2, 3, 1, 1};  // 2 x 3 = 6 volumes of 24 samples
  const auto stored = ramp_i16(144);
  write_bytes(dir / "5d.nii", with_samples(h, stored));
  for (std::int64_t t : {0, 1, 5}) {
    io::ReadOptions options;
    options.volume = t;
    auto source = io::open_volume(dir / "5d.nii", options);
    EXPECT_EQ(source->info().volumes, 6);
    expect_samples(source->read_all(), std::vector<std::int16_t>(stored.begin() + 24 * t, stored.begin() + 24 * (t + 1)));
  }
  io::ReadOptions past;
  past.volume = 6;
  expect_error([&] { io::open_volume(dir / "5d.nii", past); }, {"5d.nii", "volume 6 does not exist", "holds 6"});
  // Truncated inside the last volume: that volume is refused, the ones before still read.
  auto cut = with_samples(h, stored);
  cut.resize(cut.size() - 2);
  write_bytes(dir / "cut.nii", cut);
  past.volume = 5;
  expect_error([&] { io::read_volume(dir / "cut.nii", past); }, {"cut.nii", "dim"});
  past.volume = 4;
  EXPECT_EQ(io::read_volume(dir / "cut.nii", past).dims(), (Extent{4, 3, 2}));
  // Formats of one volume take only volume 0.
  io::write_volume(dir / "one.nrrd", Volume(Extent{2, 2, 2}, DType::u8));
  past.volume = 1;
  expect_error([&] { io::open_volume(dir / "one.nrrd", past); }, {"one.nrrd", "volume 1 does not exist"});
  past.volume = 0;
  EXPECT_EQ(io::open_volume(dir / "one.nrrd", past)->info().volumes, 1);
}

// A NIfTI-2 header (nifti2.h, 540 bytes) written field by field: 64-bit dims and vox_offset,
// f64 pixdim and scaling, the 8-byte magic at offset 4.
std::vector<std::byte> nifti2_file(const std::array<std::int64_t, 8>& dim, const std::vector<std::int16_t>& samples,
                                   bool big_endian, double slope = 0, std::int64_t vox_offset = 544) {
  HandHeader put_in_order;
  put_in_order.big_endian = big_endian;
  std::vector<std::byte> b(static_cast<std::size_t>(vox_offset), std::byte{0});
  put_in_order.put(b, 0, std::int32_t(540));
  std::memcpy(b.data() + 4, "n+2\0\r\n\032\n", 8);
  put_in_order.put(b, 12, std::int16_t(4));   // datatype i16
  put_in_order.put(b, 14, std::int16_t(16));  // bitpix
  for (std::size_t i = 0; i < 8; ++i) put_in_order.put(b, 16 + 8 * i, dim[i]);
  const std::array<double, 8> pixdim{1, 0.5, 2.0, 3.25, 1, 1, 1, 1};
  for (std::size_t i = 0; i < 8; ++i) put_in_order.put(b, 104 + 8 * i, pixdim[i]);
  put_in_order.put(b, 168, vox_offset);
  put_in_order.put(b, 176, slope);
  put_in_order.put(b, 184, 0.5);  // scl_inter, used only with a slope
  for (std::int16_t v : samples) {
    std::byte raw[2];
    std::memcpy(raw, &v, 2);
    if (big_endian) std::swap(raw[0], raw[1]);
    b.insert(b.end(), raw, raw + 2);
  }
  return b;
}

TEST(IoNifti2, ReadsEitherByteOrderWithItsSpacingAndScaling) {
  TempDir dir;
  const auto stored = ramp_i16(24);
  for (const bool big : {false, true}) {
    const fs::path p = dir / (big ? "be.nii" : "le.nii");
    write_bytes(p, nifti2_file({3, 4, 3, 2, 1, 1, 1, 1}, stored, big));
    auto source = io::open_volume(p);
    EXPECT_EQ(source->info().dims, (Extent{4, 3, 2}));
    EXPECT_EQ(source->info().dtype, DType::i16);
    EXPECT_EQ(source->info().spacing, (Spacing{0.5, 2.0, 3.25}));
    expect_samples(source->read_all(), stored);
  }
  // Scaling in f64: value = stored * 2 + 0.5.
  write_bytes(dir / "scaled.nii", nifti2_file({3, 4, 3, 2, 1, 1, 1, 1}, stored, false, 2.0));
  const Volume scaled = io::read_volume(dir / "scaled.nii");
  ASSERT_EQ(scaled.dtype(), DType::f32);
  for (std::size_t i = 0; i < stored.size(); ++i) EXPECT_EQ(scaled.samples<float>()[i], float(stored[i]) * 2.0f + 0.5f);
  // vox_offset beyond the header (extensions), and a second volume.
  write_bytes(dir / "ext.nii", nifti2_file({4, 4, 3, 1, 2, 1, 1, 1}, stored, false, 0, 608));
  io::ReadOptions second;
  second.volume = 1;
  expect_samples(io::read_volume(dir / "ext.nii", second), std::vector<std::int16_t>(stored.begin() + 12, stored.end()));
  // The pair magic and a vox_offset inside the header are refused by name.
  auto pair = nifti2_file({3, 4, 3, 2, 1, 1, 1, 1}, stored, false);
  pair[5] = std::byte{'i'};
  pair[6] = std::byte{'2'};
  write_bytes(dir / "pair.nii", pair);
  expect_error([&] { io::open_volume(dir / "pair.nii"); }, {"pair.nii", "magic", "ni2"});
  write_bytes(dir / "inside.nii", nifti2_file({3, 4, 3, 2, 1, 1, 1, 1}, stored, false, 0, 544));
  auto inside = read_bytes(dir / "inside.nii");
  HandHeader{}.put(inside, 168, std::int64_t(100));
  write_bytes(dir / "inside.nii", inside);
  expect_error([&] { io::open_volume(dir / "inside.nii"); }, {"inside.nii", "vox_offset", "540"});
}

// A dimension beyond NIfTI-1's 16-bit dim is written as NIfTI-2 and reads back exactly; smaller
// volumes stay NIfTI-1, which every reader takes.
TEST(IoNifti2, WriterUsesNifti2OnlyForDimensionsNifti1CannotHold) {
  TempDir dir;
  Volume wide(Extent{40000, 2, 1}, DType::u16, Spacing{0.25, 1, 2});
  auto s = wide.samples<std::uint16_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::uint16_t(i * 7919u);
  for (const char* name : {"wide.nii", "wide.nii.gz"}) {
    io::write_volume(dir / name, wide);
    const Volume back = io::read_volume(dir / name);
    EXPECT_EQ(back, wide) << name;
    EXPECT_EQ(back.spacing(), wide.spacing()) << name;
  }
  const auto bytes = read_bytes(dir / "wide.nii");
  std::int32_t sizeof_hdr = 0;
  std::memcpy(&sizeof_hdr, bytes.data(), 4);
  EXPECT_EQ(sizeof_hdr, 540);
  EXPECT_EQ(bytes.size(), 544u + 40000u * 2u * 2u);
  io::write_volume(dir / "small.nii", Volume(Extent{3, 2, 1}, DType::u8));
  std::memcpy(&sizeof_hdr, read_bytes(dir / "small.nii").data(), 4);
  EXPECT_EQ(sizeof_hdr, 348);
}

TEST(IoNifti, HonoursVoxOffsetBeyondTheHeader) {
  TempDir dir;
  HandHeader h;
  h.vox_offset = 400;  // room for extensions, which we skip
  auto bytes = h.bytes();
  bytes.resize(400, std::byte{0x7f});
  const auto stored = ramp_i16(24);
  const auto data = with_samples(HandHeader{}, stored);
  bytes.insert(bytes.end(), data.begin() + 352, data.end());
  write_bytes(dir / "ext.nii", bytes);
  expect_samples(io::read_volume(dir / "ext.nii"), stored);
}

// ---------------------------------------------------------------------------------------------
// Corrupt inputs: the message names the file and the header field.

TEST(IoNiftiErrors, TruncatedData) {
  TempDir dir;
  auto bytes = with_samples(HandHeader{}, ramp_i16(24));
  bytes.resize(bytes.size() - 5);
  write_bytes(dir / "short.nii", bytes);
  expect_error([&] { io::read_volume(dir / "short.nii"); }, {"short.nii", "dim"});
}

TEST(IoNiftiErrors, TruncatedHeader) {
  TempDir dir;
  auto bytes = HandHeader{}.bytes();
  bytes.resize(200);
  write_bytes(dir / "stub.nii", bytes);
  expect_error([&] { io::read_volume(dir / "stub.nii"); }, {"stub.nii", "sizeof_hdr"});
}

TEST(IoNiftiErrors, BadMagic) {
  TempDir dir;
  HandHeader h;
  h.magic = {'x', 'y', 'z', '\0'};
  write_bytes(dir / "magic.nii", with_samples(h, ramp_i16(24)));
  expect_error([&] { io::read_volume(dir / "magic.nii"); }, {"magic.nii", "magic"});
  h.magic = {'n', 'i', '1', '\0'};  // a .hdr/.img pair header is not a single file
  write_bytes(dir / "pair.nii", with_samples(h, ramp_i16(24)));
  expect_error([&] { io::read_volume(dir / "pair.nii"); }, {"pair.nii", "magic"});
}

TEST(IoNiftiErrors, BadSizeofHdr) {
  TempDir dir;
  HandHeader h;
  h.sizeof_hdr = 123;
  write_bytes(dir / "hdr.nii", with_samples(h, ramp_i16(24)));
  expect_error([&] { io::read_volume(dir / "hdr.nii"); }, {"hdr.nii", "sizeof_hdr", "348 (NIfTI-1) or 540 (NIfTI-2)"});
  // 540 announces a NIfTI-2 header, which a 400-byte file cannot hold.
  h.sizeof_hdr = 540;
  write_bytes(dir / "short2.nii", with_samples(h, ramp_i16(24)));
  expect_error([&] { io::read_volume(dir / "short2.nii"); }, {"short2.nii", "sizeof_hdr", "540-byte NIfTI-2"});
}

TEST(IoNiftiErrors, UnsupportedDatatypeAndWrongBitpix) {
  TempDir dir;
  HandHeader h;
  h.datatype = 128;  // RGB24
  h.bitpix = 24;
  write_bytes(dir / "rgb.nii", with_samples(h, std::vector<std::uint8_t>(72)));
  expect_error([&] { io::read_volume(dir / "rgb.nii"); }, {"rgb.nii", "datatype"});
  h.datatype = 4;  // i16 claimed as 8 bits would read the wrong byte count
  h.bitpix = 8;
  write_bytes(dir / "bitpix.nii", with_samples(h, ramp_i16(24)));
  expect_error([&] { io::read_volume(dir / "bitpix.nii"); }, {"bitpix.nii", "bitpix"});
}

TEST(IoNiftiErrors, BadGzip) {
  TempDir dir;
  // gzip signature followed by garbage
  std::vector<std::byte> garbage{std::byte{0x1f}, std::byte{0x8b}};
  for (int i = 0; i < 100; ++i) garbage.push_back(std::byte(i * 7));
  write_bytes(dir / "garbage.nii.gz", garbage);
  expect_error([&] { io::read_volume(dir / "garbage.nii.gz"); }, {"garbage.nii.gz", "gzip"});

  // a valid stream cut in half
  io::write_volume(dir / "whole.nii.gz", random_volume({16, 16, 8}, DType::u16, 9));
  auto gz = read_bytes(dir / "whole.nii.gz");
  gz.resize(gz.size() / 2);
  write_bytes(dir / "cut.nii.gz", gz);
  expect_error([&] { io::read_volume(dir / "cut.nii.gz"); }, {"cut.nii.gz", "gzip"});

  // a .gz name over uncompressed content
  write_bytes(dir / "plain.nii.gz", with_samples(HandHeader{}, ramp_i16(24)));
  expect_error([&] { io::read_volume(dir / "plain.nii.gz"); }, {"plain.nii.gz", "gzip"});
}

// ---------------------------------------------------------------------------------------------
// Gzip samples are decoded as passes in z order read them; random access decodes them to the
// requested temp dir, reports progress, and cleans up.

TEST(IoNifti, GzipDecodesIntoTempDirWithProgress) {
  TempDir dir;
  const Volume v = random_volume({20, 10, 5}, DType::i16, 11);
  io::write_volume(dir / "v.nii.gz", v);
  fs::create_directory(dir / "scratch");
  CountingProgress progress;
  io::ReadOptions options;
  options.temp_dir = dir / "scratch";
  options.progress = &progress;
  {
    auto source = io::open_volume(dir / "v.nii.gz", options);
    EXPECT_EQ(source->path(), dir / "v.nii.gz");
    EXPECT_TRUE(source->read_slab(3, 5) == v.crop({{0, 0, 3}, {20, 10, 5}}));
    EXPECT_FALSE(maps_a_file_in(dir / "scratch"));  // streamed so far
    // A step back: the decoded samples are mapped from temp_dir, from a file without a name.
    EXPECT_TRUE(source->read_slab(1, 2) == v.crop({{0, 0, 1}, {20, 10, 2}}));
    EXPECT_TRUE(maps_a_file_in(dir / "scratch"));
    EXPECT_EQ(file_count(dir / "scratch"), 0u);
    EXPECT_TRUE(source->read_all() == v);
  }
  EXPECT_EQ(file_count(dir / "scratch"), 0u);
  EXPECT_EQ(progress.begins, 1);
  EXPECT_EQ(progress.ends, 1);
  EXPECT_EQ(progress.advanced, v.byte_size());
}

TEST(IoNifti, UnfinishedWriterLeavesNoFile) {
  TempDir dir;
  const Volume v = random_volume({4, 4, 4}, DType::u8, 1);
  for (const char* name : {"a.nii", "a.nii.gz"}) {
    {
      auto writer = io::create_volume_writer(dir / name, v.info());
      writer->write_slab(v.crop({{0, 0, 0}, {4, 4, 2}}));
      EXPECT_THROW(writer->finish(), Error);  // 2 of 4 slices
    }
    EXPECT_FALSE(fs::exists(dir / name));
    EXPECT_FALSE(fs::exists(dir / (std::string(name) + ".tmp")));
  }
}

// ---------------------------------------------------------------------------------------------
// Real data from Debian's mricron-data package (skipped when it is not installed).

TEST(IoNiftiRealData, Colin27) {
  const auto path = test::mricron_data("ch2better.nii.gz");
  if (!path) GTEST_SKIP() << "mricron-data not installed";
  auto source = io::open_volume(*path);
  EXPECT_EQ(source->info().dims, (Extent{301, 370, 316}));
  EXPECT_EQ(source->info().dtype, DType::u8);
  EXPECT_EQ(source->info().spacing, (Spacing{0.5, 0.5, 0.5}));
  const Volume slab = source->read_slab(150, 160);
  const auto s = slab.samples<std::uint8_t>();
  EXPECT_GT(*std::max_element(s.begin(), s.end()), 0);  // the middle of a brain is not empty
}

TEST(IoNiftiRealData, AalAtlasLabels) {
  const auto path = test::mricron_data("aal.nii.gz");
  if (!path) GTEST_SKIP() << "mricron-data not installed";
  const Volume v = io::read_volume(*path);
  EXPECT_EQ(v.dims(), (Extent{181, 217, 181}));
  ASSERT_EQ(v.dtype(), DType::u8);
  const auto s = v.samples<std::uint8_t>();
  const std::set<std::uint8_t> labels(s.begin(), s.end());
  EXPECT_EQ(labels.size(), 117u);
  EXPECT_TRUE(labels.count(0));
}

// The NIfTI-2 example of python3-nibabel (the reference reader of the field; skipped when it is
// not installed): int16, 32 x 20 x 12, two volumes. Each volume equals nibabel's decode, and
// nibabel reads back the NIfTI-2 files we write.
TEST(IoNiftiRealData, NibabelNifti2ExampleEqualsNibabel) {
  const fs::path path = "/usr/lib/python3/dist-packages/nibabel/tests/data/example_nifti2.nii.gz";
  if (!fs::exists(path)) GTEST_SKIP() << "python3-nibabel not installed";
  TempDir dir;
  const std::string script = "import nibabel, numpy; a = numpy.asarray(nibabel.load('" + path.string() +
                             "').dataobj); [open('" + (dir / "v").string() +
                             "%d' % t, 'wb').write(a[..., t].astype('<i2').tobytes(order='F')) for t in range(a.shape[3])]";
  std::string out;
  ASSERT_EQ(test::run_command("/usr/bin/python3 -c \"" + script + "\"", &out), 0) << out;
  for (std::int64_t t = 0; t < 2; ++t) {
    io::ReadOptions options;
    options.volume = t;
    const Volume v = io::read_volume(path, options);
    ASSERT_EQ(v.dims(), (Extent{32, 20, 12}));
    ASSERT_EQ(v.dtype(), DType::i16);
    const auto expected = read_bytes(dir / ("v" + std::to_string(t)));
    ASSERT_EQ(expected.size(), v.byte_size());
    EXPECT_EQ(std::memcmp(expected.data(), v.bytes(), v.byte_size()), 0) << "volume " << t;
  }
  // And nibabel reads the NIfTI-2 files we write: same samples, same spacing.
  Volume wide(Extent{40000, 2, 1}, DType::u16, Spacing{0.25, 1, 2});
  auto s = wide.samples<std::uint16_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::uint16_t(i * 7919u);
  io::write_volume(dir / "wide.nii", wide);
  const std::string check = "import nibabel, numpy; i = nibabel.load('" + (dir / "wide.nii").string() +
                            "'); assert type(i).__name__ == 'Nifti2Image', type(i); "
                            "assert tuple(i.header.get_zooms()) == (0.25, 1.0, 2.0), i.header.get_zooms(); open('" +
                            (dir / "wide.raw").string() + "', 'wb').write(numpy.asarray(i.dataobj).astype('<u2').tobytes(order='F'))";
  ASSERT_EQ(test::run_command("/usr/bin/python3 -c \"" + check + "\"", &out), 0) << out;
  const auto decoded = read_bytes(dir / "wide.raw");
  ASSERT_EQ(decoded.size(), wide.byte_size());
  EXPECT_EQ(std::memcmp(decoded.data(), wide.bytes(), wide.byte_size()), 0);
}

}  // namespace
}  // namespace strata
