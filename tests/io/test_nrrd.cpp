// NRRD: round trips, hand-written headers (byte order, detached data, skips, spacing), type
// spellings and the real sample files.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <set>

#include "io/io_test_util.hpp"
#include "strata/core/threads.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

using namespace strata::test::io;

std::string as_string(const Volume& v) { return std::string(reinterpret_cast<const char*>(v.bytes()), v.byte_size()); }

// gzip made with zlib directly, so the reader is checked against an encoder that is not ours.
std::string gzip(const std::string& payload) {
  z_stream s{};
  EXPECT_EQ(deflateInit2(&s, 9, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&s, uLong(payload.size())) + 64, '\0');
  s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(payload.data()));
  s.avail_in = uInt(payload.size());
  s.next_out = reinterpret_cast<Bytef*>(out.data());
  s.avail_out = uInt(out.size());
  EXPECT_EQ(deflate(&s, Z_FINISH), Z_STREAM_END);
  out.resize(s.total_out);
  deflateEnd(&s);
  return out;
}

// Samples stored most significant byte first.
template <class T>
std::string big_endian_bytes(const std::vector<T>& values) {
  std::string out;
  for (T v : values) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    std::reverse(b, b + sizeof(T));
    out.append(b, sizeof(T));
  }
  return out;
}

template <class T>
std::string little_endian_bytes(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

std::string header(const std::string& type, const std::string& sizes, const std::string& endian,
                   const std::string& encoding, const std::string& extra = "") {
  return "NRRD0004\ntype: " + type + "\ndimension: 3\nsizes: " + sizes + "\nendian: " + endian +
         "\nencoding: " + encoding + "\n" + extra;
}

class IoNrrdRoundTrip : public ::testing::TestWithParam<bool> {};

TEST_P(IoNrrdRoundTrip, IsBitExactForEveryDtype) {
  const bool compress = GetParam();
  test::TempDir dir;
  for (DType t : kAllDtypes) {
    SCOPED_TRACE(std::string(dtype_name(t)));
    Volume original = random_bytes_volume({7, 5, 3}, t, 21);
    auto path = dir / ("v_" + std::string(dtype_name(t)) + ".nrrd");
    write_volume(path, original, with_compression(compress));
    const std::string file = read_text(path);
    EXPECT_NE(file.find(compress ? "encoding: gzip\n" : "encoding: raw\n"), std::string::npos);
    if (!compress) {  // header + exactly the samples, nothing else
      EXPECT_EQ(file.substr(file.size() - original.byte_size()), as_string(original));
    }
    expect_same(read_volume(path), original);
  }
}

INSTANTIATE_TEST_SUITE_P(Encodings, IoNrrdRoundTrip, ::testing::Values(true, false),
                         [](const auto& info) { return info.param ? "gzip" : "raw"; });

TEST(IoNrrd, GzipWriterOutputIsAGzipStreamAfterTheHeader) {
  test::TempDir dir;
  Volume original = random_bytes_volume({4, 4, 4}, DType::u8, 2);
  write_volume(dir / "g.nrrd", original);  // compress is the default
  const std::string file = read_text(dir / "g.nrrd");
  const auto data = file.find("\n\n") + 2;
  ASSERT_LT(data + 2, file.size());
  EXPECT_EQ(static_cast<unsigned char>(file[data]), 0x1f);
  EXPECT_EQ(static_cast<unsigned char>(file[data + 1]), 0x8b);
}

TEST(IoGzipWriter, ChunkedStreamIsOneMemberThatZlibDecodesAndTheSameOnAnyThreadCount) {
  // 9.5 MiB of compressible bytes, written in uneven pieces: several batches of 1 MiB chunks,
  // each compressed on its own with the previous 32 KiB as its dictionary.
  std::vector<unsigned char> data(std::size_t(19) << 19);
  std::uint32_t state = 7;
  for (std::size_t i = 0; i < data.size(); ++i) {
    state = state * 1664525u + 1013904223u;
    data[i] = static_cast<unsigned char>((i / 3) % 251 + ((state >> 28) & 1u));
  }
  test::TempDir dir;
  auto write = [&](const std::filesystem::path& p) {
    io::AtomicOutputFile out(p);
    io::detail::GzipWriter gz(out);
    for (std::size_t at = 0; at < data.size();) {
      const std::size_t n = std::min<std::size_t>(data.size() - at, 3 * 1000 * 1000 + at % 7);
      gz.write(data.data() + at, n);
      at += n;
    }
    gz.finish();
    out.commit();
  };
  set_thread_count(1);
  write(dir / "one.gz");
  set_thread_count(2);
  write(dir / "two.gz");
  set_thread_count(0);
  const std::string one = read_text(dir / "one.gz");
  EXPECT_EQ(one, read_text(dir / "two.gz"));
  // Within 1% of one deflate stream over everything (the dictionaries carry the context).
  uLongf whole = compressBound(uLong(data.size()));
  std::vector<unsigned char> single(whole);
  ASSERT_EQ(compress2(single.data(), &whole, data.data(), uLong(data.size()), 6), Z_OK);
  EXPECT_LT(double(one.size()), 1.01 * double(whole));
  // zlib's own gzip decoder (windowBits 15 + 16) reads it as one member, CRC and size checked.
  std::vector<unsigned char> decoded(data.size() + 1);
  z_stream s{};
  ASSERT_EQ(inflateInit2(&s, 15 + 16), Z_OK);
  s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(one.data()));
  s.avail_in = uInt(one.size());
  s.next_out = decoded.data();
  s.avail_out = uInt(decoded.size());
  EXPECT_EQ(inflate(&s, Z_FINISH), Z_STREAM_END);
  EXPECT_EQ(s.avail_in, 0u);  // one member: nothing after its trailer
  decoded.resize(decoded.size() - s.avail_out);
  inflateEnd(&s);
  EXPECT_TRUE(decoded == data);
}

TEST(IoGzipWriter, EmptyInputIsAValidStream) {
  test::TempDir dir;
  write_gzipped(dir / "empty.gz", "", 0);
  const std::string file = read_text(dir / "empty.gz");
  const auto bytes = reinterpret_cast<const std::byte*>(file.data());
  EXPECT_TRUE(io::detail::gunzip_to_memory(bytes, file.size(), "empty.gz", "data").empty());
}

TEST(IoNrrd, ReadsBigEndianRawAndGzip) {
  test::TempDir dir;
  const std::vector<std::int16_t> shorts = {-30000, -2, -1, 0, 1, 258, 1000, 32767, 7, -7, 300, -300};
  const std::vector<float> floats = {1.5f, -2.25f, 3e-5f, -4e7f, 0.f, 1.f};
  const std::vector<std::uint32_t> uints = {0x01020304u, 0xA0B0C0D0u};
  write_text(dir / "s.nrrd", header("short", "3 2 2", "big", "raw") + "\n" + big_endian_bytes(shorts));
  write_text(dir / "f.nrrd", header("float", "1 2 3", "big", "gzip") + "\n" + gzip(big_endian_bytes(floats)));
  write_text(dir / "u.nrrd", header("unsigned int", "2 1 1", "big", "raw") + "\n" + big_endian_bytes(uints));

  Volume s = read_volume(dir / "s.nrrd");
  EXPECT_EQ(s.dtype(), DType::i16);
  EXPECT_EQ(as_string(s), little_endian_bytes(shorts));
  Volume f = read_volume(dir / "f.nrrd");
  EXPECT_EQ(f.dims(), (Extent{1, 2, 3}));
  EXPECT_EQ(as_string(f), little_endian_bytes(floats));
  Volume u = read_volume(dir / "u.nrrd");
  EXPECT_EQ(u.value(0, 0, 0), double(0x01020304u));
  EXPECT_EQ(u.value(1, 0, 0), double(0xA0B0C0D0u));
}

TEST(IoNrrd, BigEndianSubBoxesMatchTheWhole) {
  test::TempDir dir;
  std::vector<std::uint16_t> values(5 * 4 * 3);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = std::uint16_t(i * 1031 + 7);
  write_text(dir / "b.nrrd", header("uint16", "5 4 3", "big", "raw") + "\n" + big_endian_bytes(values));
  auto source = open_volume(dir / "b.nrrd");
  Volume whole = source->read_all();
  EXPECT_EQ(as_string(whole), little_endian_bytes(values));
  const Box box{{1, 1, 1}, {4, 3, 3}};
  EXPECT_TRUE(source->read_box(box) == whole.crop(box));
}

TEST(IoNrrd, AcceptsEveryTypeSpelling) {
  const std::vector<std::pair<std::string, DType>> spellings = {
      {"uchar", DType::u8},          {"unsigned char", DType::u8},   {"uint8", DType::u8},
      {"uint8_t", DType::u8},        {"signed char", DType::i8},     {"int8", DType::i8},
      {"int8_t", DType::i8},         {"short", DType::i16},          {"short int", DType::i16},
      {"signed short", DType::i16},  {"signed short int", DType::i16}, {"int16", DType::i16},
      {"int16_t", DType::i16},       {"ushort", DType::u16},         {"unsigned short", DType::u16},
      {"unsigned short int", DType::u16}, {"uint16", DType::u16},    {"uint16_t", DType::u16},
      {"int", DType::i32},           {"signed int", DType::i32},     {"int32", DType::i32},
      {"int32_t", DType::i32},       {"uint", DType::u32},           {"unsigned int", DType::u32},
      {"uint32", DType::u32},        {"uint32_t", DType::u32},       {"float", DType::f32},
      {"double", DType::f64}};
  test::TempDir dir;
  for (const auto& [spelling, dtype] : spellings) {
    SCOPED_TRACE(spelling);
    write_text(dir / "t.nrrd",
               header(spelling, "2 1 1", "little", "raw") + "\n" + std::string(2 * dtype_size(dtype), '\x01'));
    auto source = open_volume(dir / "t.nrrd");
    EXPECT_EQ(source->info().dtype, dtype);
    EXPECT_EQ(source->info().dims, (Extent{2, 1, 1}));
  }
}

TEST(IoNrrd, DetachedHeaderWithRawAndGzipData) {
  test::TempDir dir;
  const std::vector<std::int32_t> values = {-5, 4, -3, 2, -1, 0, 1, 2};
  std::filesystem::create_directory(dir / "data");
  write_text(dir / "data" / "vol.raw", little_endian_bytes(values));
  write_text(dir / "data" / "vol.raw.gz", gzip(little_endian_bytes(values)));
  write_text(dir / "r.nhdr", header("int32", "2 2 2", "little", "raw", "data file: data/vol.raw\n"));
  write_text(dir / "g.nhdr", header("int32", "2 2 2", "little", "gz", "datafile: data/vol.raw.gz\n"));
  for (const char* name : {"r.nhdr", "g.nhdr"}) {
    SCOPED_TRACE(name);
    Volume v = read_volume(dir / name);
    EXPECT_EQ(v.dims(), (Extent{2, 2, 2}));
    EXPECT_EQ(as_string(v), little_endian_bytes(values));
  }
}

TEST(IoNrrd, WritingANhdrNameGivesADetachedPair) {
  test::TempDir dir;
  Volume original = random_bytes_volume({3, 4, 5}, DType::u16, 8);
  for (bool compress : {true, false}) {
    SCOPED_TRACE(compress);
    write_volume(dir / "d.nhdr", original, with_compression(compress));
    const std::string data_name = compress ? "d.raw.gz" : "d.raw";
    EXPECT_TRUE(std::filesystem::exists(dir / data_name));
    EXPECT_NE(read_text(dir / "d.nhdr").find("data file: " + data_name), std::string::npos);
    EXPECT_TRUE(read_volume(dir / "d.nhdr") == original);
  }
}

TEST(IoNrrd, SpacingsAndSpaceDirectionsGiveSpacing) {
  test::TempDir dir;
  const std::string data(8, '\x05');
  write_text(dir / "a.nrrd", header("uchar", "2 2 2", "little", "raw", "spacings: 0.5 0.25 3\n") + "\n" + data);
  write_text(dir / "b.nrrd",
             header("uchar", "2 2 2", "little", "raw",
                    "space: left-posterior-superior\nspace directions: (0.7,0,0) (0, -0.8, 0) (0,0,2.5)\n"
                    "space origin: (1,2,3)\n") +
                 "\n" + data);
  write_text(dir / "c.nrrd", header("uchar", "2 2 2", "little", "raw", "spacings: nan 2 nan\n") + "\n" + data);
  EXPECT_EQ(open_volume(dir / "a.nrrd")->info().spacing, (Spacing{0.5, 0.25, 3}));
  EXPECT_EQ(open_volume(dir / "b.nrrd")->info().spacing, (Spacing{0.7, 0.8, 2.5}));
  EXPECT_EQ(open_volume(dir / "c.nrrd")->info().spacing, (Spacing{1, 2, 1}));
}

TEST(IoNrrd, SpacingWithManyDigitsSurvivesARoundTrip) {
  test::TempDir dir;
  Volume v(Extent{2, 2, 2}, DType::u8, Spacing{0.1, 1.0 / 3.0, 12345.678901234567});
  write_volume(dir / "sp.nrrd", v);
  EXPECT_EQ(read_volume(dir / "sp.nrrd").spacing(), v.spacing());
}

TEST(IoNrrd, CommentsKeyValuesAndOtherFieldsAreIgnored) {
  test::TempDir dir;
  const std::vector<std::uint16_t> values = {1, 2, 3, 4, 5, 6, 7, 8};
  write_text(dir / "c.nrrd", "NRRD0005\r\n# a comment: with a colon\r\ncontent: test\r\ntype: ushort\r\n"
                             "dimension: 3\r\nsizes: 2 2 2\r\nkinds: domain domain domain\r\nmodality:=CT\r\n"
                             "endian: little\r\nencoding: raw\r\n\r\n" +
                                 little_endian_bytes(values));
  EXPECT_EQ(as_string(read_volume(dir / "c.nrrd")), little_endian_bytes(values));
}

TEST(IoNrrd, ByteSkipAndLineSkipLocateTheData) {
  test::TempDir dir;
  const std::vector<std::uint16_t> values = {10, 20, 30, 40};
  write_text(dir / "bs.nrrd", header("uint16", "2 2 1", "little", "raw", "byte skip: 3\n") + "\nXYZ" +
                                  little_endian_bytes(values));
  write_text(dir / "end.nrrd", header("uint16", "2 2 1", "little", "raw", "byte skip: -1\n") + "\njunk" +
                                   little_endian_bytes(values));
  write_text(dir / "ls.nrrd", header("uint16", "2 2 1", "little", "raw", "line skip: 2\n") + "\nfirst\nsecond\n" +
                                  little_endian_bytes(values));
  // With gzip, byte skip counts decoded bytes.
  write_text(dir / "gbs.nrrd", header("uint16", "2 2 1", "little", "gzip", "byte skip: 2\n") + "\n" +
                                   gzip("##" + little_endian_bytes(values)));
  for (const char* name : {"bs.nrrd", "end.nrrd", "ls.nrrd", "gbs.nrrd"}) {
    SCOPED_TRACE(name);
    EXPECT_EQ(as_string(read_volume(dir / name)), little_endian_bytes(values));
  }
}

TEST(IoNrrd, FourDimensionsWithAUnitFirstAxisReadAsThree) {
  test::TempDir dir;
  const std::vector<std::uint8_t> values = {1, 2, 3, 4, 5, 6};
  write_text(dir / "4d.nrrd", "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 1 3 2 1\nspacings: nan 0.5 0.5 2\n"
                              "encoding: raw\n\n" + little_endian_bytes(values));
  Volume v = read_volume(dir / "4d.nrrd");
  EXPECT_EQ(v.dims(), (Extent{3, 2, 1}));
  EXPECT_EQ(v.spacing(), (Spacing{0.5, 0.5, 2}));
  EXPECT_EQ(as_string(v), little_endian_bytes(values));
}

TEST(IoNrrd, ReadBoxOfSubBoxEqualsCropOfWholeForBothEncodings) {
  test::TempDir dir;
  Volume original = random_bytes_volume({11, 9, 6}, DType::i32, 4);
  for (bool compress : {true, false}) {
    SCOPED_TRACE(compress);
    write_volume(dir / "box.nrrd", original, with_compression(compress));
    auto source = open_volume(dir / "box.nrrd");
    for (Box box : {Box{{2, 3, 1}, {9, 8, 5}}, Box{{0, 0, 5}, {11, 9, 6}}, Box{{0, 4, 0}, {11, 5, 6}},
                    Box{{10, 0, 0}, {11, 9, 6}}}) {
      SCOPED_TRACE(box.to_string());
      EXPECT_TRUE(source->read_box(box) == original.crop(box));
    }
    EXPECT_THROW(source->read_box({{0, 0, 0}, {12, 9, 6}}), Error);
  }
}

TEST(IoNrrdRealData, FibsemGroundTruthLabels) {
  auto path = test::shared_data("fibsem_medulla_250_gt.nrrd");
  if (!path) GTEST_SKIP() << "shared data not installed";
  auto source = open_volume(*path);
  EXPECT_EQ(source->info().dims, (Extent{250, 250, 250}));
  EXPECT_EQ(source->info().dtype, DType::u32);
  EXPECT_EQ(source->info().spacing, (Spacing{10, 10, 10}));
  // A slab and a sub-box agree with the same region of the whole volume.
  Volume whole = source->read_all();
  EXPECT_TRUE(source->read_slab(100, 110) == whole.crop({{0, 0, 100}, {250, 250, 110}}));
  EXPECT_TRUE(source->read_box({{17, 33, 200}, {99, 120, 249}}) == whole.crop({{17, 33, 200}, {99, 120, 249}}));
  const auto labels = whole.samples<std::uint32_t>();
  std::set<std::uint32_t> ids(labels.begin(), labels.end());
  EXPECT_GE(ids.size(), 525u);  // the README lists 525 labels (plus possibly background)
  EXPECT_LE(ids.size(), 526u);
}

TEST(IoNrrdRealData, FrogTissueLabels) {
  auto path = test::shared_data("vtk_frog_tissue.nrrd");
  if (!path) GTEST_SKIP() << "shared data not installed";
  Volume v = read_volume(*path);
  EXPECT_EQ(v.dims(), (Extent{500, 470, 136}));
  EXPECT_EQ(v.dtype(), DType::u8);
  EXPECT_EQ(v.spacing(), (Spacing{1, 1, 1.5}));
  const auto samples = v.samples<std::uint8_t>();
  const auto zeros = std::count(samples.begin(), samples.end(), std::uint8_t{0});
  EXPECT_GT(double(zeros) / double(samples.size()), 0.9);  // "96% background"
  const std::set<std::uint8_t> ids(samples.begin(), samples.end());
  EXPECT_GE(ids.size(), 25u);  // the README lists 25 labels (plus possibly background)
  EXPECT_LE(ids.size(), 26u);
}


// ---- Several volumes: a fourth axis of components (first, interleaved) or times (last) ------

std::string nrrd4(const std::string& type, const std::string& sizes, const std::string& kinds, const std::string& encoding) {
  return "NRRD0004\ntype: " + type + "\ndimension: 4\nsizes: " + sizes + "\nkinds: " + kinds +
         "\nspacings: nan 0.5 0.5 2\nendian: little\nencoding: " + encoding + "\n\n";
}

TEST(IoNrrd, InterleavedComponentsAndSeriesReadOneVolumeEach) {
  test::TempDir dir;
  // 3 x 4 x 2 voxels: RGB components first (component fastest), or 3 time points last.
  std::vector<std::uint16_t> rgb(3 * 24), series(24 * 3);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = std::uint16_t(1000 + 7 * i);
  for (std::size_t i = 0; i < series.size(); ++i) series[i] = std::uint16_t(5 * i);
  write_text(dir / "rgb.nrrd", nrrd4("uint16", "3 3 4 2", "RGB-color domain domain domain", "raw") + little_endian_bytes(rgb));
  write_text(dir / "rgb_gz.nrrd", nrrd4("uint16", "3 3 4 2", "vector space space space", "gzip") + gzip(little_endian_bytes(rgb)));
  std::string series_header = nrrd4("uint16", "3 4 2 3", "domain domain domain time", "raw");
  series_header.replace(series_header.find("nan 0.5 0.5 2"), 13, "0.5 0.5 2 nan");
  write_text(dir / "series.nrrd", series_header + little_endian_bytes(series));
  for (const char* name : {"rgb.nrrd", "rgb_gz.nrrd"}) {
    for (std::int64_t c = 0; c < 3; ++c) {
      ReadOptions o;
      o.volume = c;
      const auto source = open_volume(dir / name, o);
      EXPECT_EQ(source->info().volumes, 3);
      EXPECT_EQ(source->info().dims, (Extent{3, 4, 2}));
      EXPECT_DOUBLE_EQ(source->info().spacing.z, 2.0);
      const Volume v = source->read_all();
      for (std::int64_t i = 0; i < 24; ++i) ASSERT_EQ(v.samples<std::uint16_t>()[std::size_t(i)], rgb[std::size_t(3 * i + c)]) << name << " " << c;
      // A box in the middle reads the same samples as the whole.
      const Volume box = source->read_box({{1, 1, 1}, {3, 3, 2}});
      EXPECT_EQ(box.samples<std::uint16_t>()[0], rgb[std::size_t(3 * (1 + 3 * (1 + 4 * 1)) + c)]);
    }
  }
  for (std::int64_t t = 0; t < 3; ++t) {
    ReadOptions o;
    o.volume = t;
    const Volume v = read_volume(dir / "series.nrrd", o);
    for (std::int64_t i = 0; i < 24; ++i) ASSERT_EQ(v.samples<std::uint16_t>()[std::size_t(i)], series[std::size_t(24 * t + i)]);
  }
}

TEST(IoNrrd, SeveralVolumesNeedTheirKindsAndAChoice) {
  test::TempDir dir;
  const std::string data(3 * 24 * 2, '\0');
  write_text(dir / "nokinds.nrrd", "NRRD0004\ntype: uint16\ndimension: 4\nsizes: 3 3 4 2\nendian: little\nencoding: raw\n\n" + data);
  write_text(dir / "twoaxes.nrrd", nrrd4("uint16", "3 3 4 2", "vector list domain domain", "raw") + data);
  write_text(dir / "middle.nrrd", nrrd4("uint16", "3 3 4 2", "domain vector domain domain", "raw") + data);
  write_text(dir / "spatial.nrrd", nrrd4("uint16", "3 3 4 2", "domain domain domain domain", "raw") + data);
  write_text(dir / "short.nrrd", nrrd4("uint16", "3 3 4 2", "vector domain domain domain", "raw") + data.substr(2));
  write_text(dir / "ok.nrrd", nrrd4("uint16", "3 3 4 2", "vector domain domain domain", "raw") + data);
  for (const char* name : {"nokinds.nrrd", "twoaxes.nrrd", "middle.nrrd", "spatial.nrrd"})
    EXPECT_NE(test::error_of([&] { open_volume(dir / name); }).find(std::string(name) + ": kinds: "), std::string::npos) << name;
  ReadOptions first;
  first.volume = 0;
  EXPECT_NE(test::error_of([&] { open_volume(dir / "short.nrrd", first); }).find("3 volumes of 3x4x2"), std::string::npos);
  EXPECT_NE(test::error_of([&] { open_volume(dir / "ok.nrrd"); }).find("choose one with --volume T (0..2)"), std::string::npos);
  ReadOptions fourth;
  fourth.volume = 3;
  EXPECT_EQ(test::parameter_of([&] { open_volume(dir / "ok.nrrd", fourth); }), "ReadOptions::volume");
}

}  // namespace
}  // namespace strata::io
