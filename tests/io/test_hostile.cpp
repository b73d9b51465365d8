// Hostile inputs: headers whose sizes overflow 64 bits, gzip streams that inflate far beyond
// what the header declares, decoded temporaries that must never outlive the process, voxel
// sizes that are not sizes, and sidecars of the wrong JSON types. Every case fails fast with a
// message naming the file and the field, without library text (std::bad_alloc, json.exception).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "io/io_detail.hpp"
#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using namespace strata::test::io;

// Opens `path` and reads it whole; expects a strata::Error holding the file name and `parts`,
// and none of the texts the standard and JSON libraries put in their own exceptions.
void expect_clear_error(const fs::path& path, const std::vector<std::string>& parts, const ReadOptions& options = {}) {
  SCOPED_TRACE(path.string());
  const std::string message = test::error_of([&] { open_volume(path, options)->read_all(); });
  ASSERT_FALSE(message.empty()) << "expected a strata::Error";
  EXPECT_NE(message.find(path.filename().string()), std::string::npos) << message;
  for (const auto& part : parts) EXPECT_NE(message.find(part), std::string::npos) << "\"" << part << "\" missing from: " << message;
  for (const char* library_text : {"bad_alloc", "json.exception", "_M_range_check", "type must be"})
    EXPECT_EQ(message.find(library_text), std::string::npos) << message;
}

std::string nrrd(const std::string& fields) { return "NRRD0004\n" + fields + "\n"; }

std::string gzipped(const fs::path& scratch, const std::string& payload) {
  write_gzipped(scratch, payload.data(), payload.size());
  std::string bytes = read_text(scratch);
  fs::remove(scratch);
  return bytes;
}

// ---------------------------------------------------------------------------------------------
// 1. dims × sample size overflowing 64 bits

TEST(IoHostile, NrrdSizesWhoseByteCountWrapsAreRejected) {
  test::TempDir dir;
  // 2^62 x 4 x 1 uint16 is 2^65 bytes: modulo 2^64 that is 0, which an empty data section matched.
  write_text(dir / "wrap.nrrd", nrrd("type: uint16\ndimension: 3\nsizes: 4611686018427387904 4 1\nendian: little\n"
                                     "encoding: raw\n"));
  expect_clear_error(dir / "wrap.nrrd", {"sizes", "64-bit"});
  // 2^104 voxels: wrapped to 0 bytes per slice and 2^40 slices to stream.
  write_text(dir / "hang.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 4294967296 4294967296 1099511627776\n"
                                     "encoding: raw\n"));
  expect_clear_error(dir / "hang.nrrd", {"sizes", "64-bit"});
  // The same sizes with gzip data: rejected before anything is decoded.
  write_text(dir / "gz.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 4294967296 4294967296 1099511627776\n"
                                   "encoding: gzip\n") + gzipped(dir / "scratch.gz", "x"));
  expect_clear_error(dir / "gz.nrrd", {"sizes", "64-bit"});
}

TEST(IoHostile, NrrdByteSkipPlusDataSizeOverflowIsRejected) {
  test::TempDir dir;
  write_text(dir / "skip.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: gzip\n"
                                     "byte skip: 9223372036854775807\n") + gzipped(dir / "scratch.gz", "x"));
  expect_clear_error(dir / "skip.nrrd", {"byte skip"});
}

TEST(IoHostile, RawSidecarDimsWhoseByteCountWrapsAreRejected) {
  test::TempDir dir;
  write_text(dir / "big.raw", "x");
  // 2^96 u16 samples: 2^97 bytes, 0 modulo 2^64.
  write_text(dir / "big.raw.json", R"({"dims":[4294967296,4294967296,4294967296],"dtype":"u16"})");
  expect_clear_error(dir / "big.raw", {"big.raw.json", "dims", "64-bit"});
  // Options with such dims are the caller's mistake: a ParameterError.
  ReadOptions options;
  options.raw_dims = Extent{std::int64_t(1) << 32, std::int64_t(1) << 32, std::int64_t(1) << 32};
  options.raw_dtype = DType::u16;
  EXPECT_EQ(test::parameter_of([&] { open_volume(dir / "big.raw", options); }), "ReadOptions::raw_dims");
  // A header size that wraps the total.
  write_text(dir / "big.raw.json", R"({"dims":[1,1,1],"dtype":"u8","header_bytes":18446744073709551615})");
  expect_clear_error(dir / "big.raw", {"big.raw.json", "64-bit"});
}

TEST(IoHostile, MappedSourceChecksTheByteCountItself) {
  test::TempDir dir;
  write_text(dir / "one.bin", "x");
  auto file = std::make_shared<MappedFile>(dir / "one.bin");
  const VolumeInfo info{{std::int64_t(1) << 62, 4, 1}, DType::u16, {}};
  expect_error([&] { detail::make_mapped_source(file, 0, info, false, dir / "one.bin", "dims"); },
               {"one.bin", "dims", "64-bit"});
}

// ---------------------------------------------------------------------------------------------
// 6. gzip bombs: decoding stops one byte past the declared size

// 16 MiB of zeros (about 16 KiB of gzip) whose CRC trailer is broken: decoding the whole stream
// would report the bad checksum, so an error about the declared size proves decoding stopped early.
std::string bomb_stream(const fs::path& scratch, const std::string& prefix) {
  std::string gz = gzipped(scratch, prefix + std::string(std::size_t(16) << 20, '\0'));
  for (std::size_t i = gz.size() - 8; i < gz.size() - 4; ++i) gz[i] = char(~gz[i]);  // CRC32
  return gz;
}

TEST(IoHostile, GzipNrrdInflatingPastItsSizesStopsThere) {
  test::TempDir dir, temp;
  write_text(dir / "bomb.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: gzip\n") +
                                    bomb_stream(dir / "scratch.gz", ""));
  ReadOptions options;
  options.temp_dir = temp.path();
  expect_clear_error(dir / "bomb.nrrd", {"data", "more than the 512 bytes", "8x8x8"}, options);
  EXPECT_EQ(file_count(temp.path()), 0u);
}

TEST(IoHostile, GzipNiftiInflatingPastItsHeaderStopsThere) {
  test::TempDir dir, temp;
  write_volume(dir / "small.nii", Volume(Extent{8, 8, 8}, DType::u8));
  write_text(dir / "bomb.nii.gz", bomb_stream(dir / "scratch.gz", read_text(dir / "small.nii")));
  ReadOptions options;
  options.temp_dir = temp.path();
  expect_clear_error(dir / "bomb.nii.gz", {"gzip", "more than the 864 bytes", "vox_offset"}, options);
  EXPECT_EQ(file_count(temp.path()), 0u);
}

TEST(IoHostile, GzipDecodingToMemoryStopsAtItsLimit) {
  test::TempDir dir;
  const std::string gz = bomb_stream(dir / "scratch.gz", "header");
  const auto* bytes = reinterpret_cast<const std::byte*>(gz.data());
  const auto head = detail::gunzip_to_memory(bytes, gz.size(), "bomb.gz", "data", 6);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(head.data()), head.size()), "header");
  expect_error([&] { detail::gunzip_to_memory(bytes, gz.size(), "bomb.gz", "data"); }, {"bomb.gz", "data", "corrupt"});
}

// ---------------------------------------------------------------------------------------------
// 8. decoded temporaries have no name while they are in use

TEST(IoHostile, DecodedGzipDataLeavesNoFileInTheTempFolder) {
  test::TempDir dir, temp;
  const Volume volume = random_bytes_volume({9, 7, 5}, DType::u16, 8);
  write_volume(dir / "v.nrrd", volume, with_compression(true));
  write_volume(dir / "v.nii.gz", volume);
  ReadOptions options;
  options.temp_dir = temp.path();
  for (const char* name : {"v.nrrd", "v.nii.gz"}) {
    SCOPED_TRACE(name);
    auto source = open_volume(dir / name, options);
    // The decoded samples are in use, yet no name exists that a kill could leave behind.
    EXPECT_EQ(file_count(temp.path()), 0u);
    EXPECT_TRUE(source->read_all() == volume);
    EXPECT_TRUE(source->read_slab(2, 4) == volume.crop({{0, 0, 2}, {9, 7, 4}}));
    EXPECT_EQ(file_count(temp.path()), 0u);
  }
}

// Passes in z order (info, convert, compress, labels encode) decode a gzip input as they go:
// with a temporary folder that does not exist they still read, so none is made. Another read
// order decodes the volume once to an unnamed temporary and reads it mapped.
TEST(IoHostile, GzipInputsStreamPassesInZOrderWithoutATemporary) {
  test::TempDir dir, temp;
  const Volume volume = random_bytes_volume({9, 7, 6}, DType::u16, 12);
  write_volume(dir / "v.nrrd", volume, with_compression(true));
  write_volume(dir / "v.nii.gz", volume);
  std::vector<std::uint16_t> series(9 * 7 * 6 * 3);
  for (std::size_t i = 0; i < series.size(); ++i) series[i] = std::uint16_t(31 * i + 7);
  write_text(dir / "series.nrrd", nrrd("type: uint16\ndimension: 4\nsizes: 9 7 6 3\nkinds: domain domain domain list\n"
                                       "endian: little\nencoding: gzip\n") +
                                      gzipped(dir / "scratch.gz", std::string(reinterpret_cast<const char*>(series.data()),
                                                                              series.size() * 2)));
  ReadOptions nowhere;
  nowhere.temp_dir = dir / "missing";
  for (const char* name : {"v.nrrd", "v.nii.gz"}) {
    SCOPED_TRACE(name);
    auto source = open_volume(dir / name, nowhere);
    for (int pass = 0; pass < 3; ++pass) {  // compress makes two passes, labels encode more
      for (std::int64_t z = 0; z < 6; z += 2) EXPECT_TRUE(source->read_slab(z, z + 2) == volume.crop({{0, 0, z}, {9, 7, z + 2}}));
      EXPECT_TRUE(source->read_box({{2, 1, 4}, {5, 6, 6}}) == volume.crop({{2, 1, 4}, {5, 6, 6}}));  // the slices held
    }
    // A step back that is not a new pass needs the temporary.
    expect_error([&] { source->read_slab(1, 3); }, {"missing", "temporary"});
  }
  for (std::int64_t t = 0; t < 3; ++t) {
    ReadOptions o = nowhere;
    o.volume = t;
    const Volume v = open_volume(dir / "series.nrrd", o)->read_all();
    for (std::size_t i = 0; i < std::size_t(v.voxel_count()); ++i)
      ASSERT_EQ(v.samples<std::uint16_t>()[i], series[std::size_t(t) * 378 + i]) << t;
  }
  // Random access: decoded once into the temporary folder, with no name, then mapped.
  ReadOptions options;
  options.temp_dir = temp.path();
  for (const char* name : {"v.nrrd", "v.nii.gz", "series.nrrd"}) {
    SCOPED_TRACE(name);
    ReadOptions o = options;
    o.volume = 1;
    if (std::string(name) != "series.nrrd") o.volume.reset();
    auto source = open_volume(dir / name, o);
    const Volume whole = open_volume(dir / name, o)->read_all();
    EXPECT_TRUE(source->read_slab(4, 6) == whole.crop({{0, 0, 4}, {9, 7, 6}}));
    EXPECT_FALSE(maps_a_file_in(temp.path()));
    EXPECT_TRUE(source->read_slab(1, 3) == whole.crop({{0, 0, 1}, {9, 7, 3}}));
    EXPECT_TRUE(maps_a_file_in(temp.path()));
    EXPECT_EQ(file_count(temp.path()), 0u);
    EXPECT_TRUE(source->read_all() == whole);
  }
}

// A small stream whose header declares more than the temporary folder holds: refused before
// anything is decoded to it, naming the file, the field, the declared size and the free space.
TEST(IoHostile, GzipDecodingForRandomAccessNeedsRoomForTheDeclaredSize) {
  test::TempDir dir, temp;
  // 2^50 bytes declared (1024 x 1024 x 2^30 u8); three slices of zeros in the stream.
  write_text(dir / "huge.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 1024 1024 1073741824\nencoding: gzip\n") +
                                    gzipped(dir / "scratch.gz", std::string(std::size_t(3) << 20, '\0')));
  ReadOptions options;
  options.temp_dir = temp.path();
  auto source = open_volume(dir / "huge.nrrd", options);
  EXPECT_EQ(source->read_slab(2, 3).voxel_count(), std::int64_t(1) << 20);  // streamed
  const std::string message = test::error_of([&] { source->read_slab(1, 2); });
  for (const char* part : {"huge.nrrd", "data", "1125899906842624 bytes (1.0 PiB)", "free", "TMPDIR"})
    EXPECT_NE(message.find(part), std::string::npos) << "\"" << part << "\" missing from: " << message;
  EXPECT_NE(message.find(temp.path().string()), std::string::npos) << message;
  EXPECT_FALSE(maps_a_file_in(temp.path()));
  // Reading on past the stream's end names the shortfall, without a temporary.
  expect_clear_error(dir / "huge.nrrd", {"data", "truncated file or wrong sizes"}, options);
}

TEST(IoHostile, UnnamedTempFileHasNoNameAndMapsWhatWasWritten) {
  test::TempDir temp;
  std::shared_ptr<MappedFile> mapped;
  {
    UnnamedTempFile file(temp.path(), "probe");
    EXPECT_EQ(file_count(temp.path()), 0u);
    file.write("hello", 5);
    mapped = std::make_shared<MappedFile>(file.descriptor(), "probe");
  }
  ASSERT_EQ(mapped->size(), 5u);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(mapped->data()), 5), "hello");
  EXPECT_EQ(file_count(temp.path()), 0u);
  expect_error([&] { UnnamedTempFile(temp / "missing", "probe"); }, {"missing", "temporary"});
}

// ---------------------------------------------------------------------------------------------
// 11. voxel sizes that are not sizes

TEST(IoHostile, NrrdSpacingsMustBePositive) {
  test::TempDir dir;
  const std::string head = "type: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n";
  write_text(dir / "zero.nrrd", nrrd(head + "spacings: 1 0 1\n") + "x");
  expect_clear_error(dir / "zero.nrrd", {"spacings", "axis 1 is 0", "positive"});
  write_text(dir / "neg.nrrd", nrrd(head + "spacings: 1 1 -2\n") + "x");
  expect_clear_error(dir / "neg.nrrd", {"spacings", "axis 2 is -2"});
  write_text(dir / "inf.nrrd", nrrd(head + "spacings: inf 1 1\n") + "x");
  expect_clear_error(dir / "inf.nrrd", {"spacings", "inf"});
  write_text(dir / "vec0.nrrd", nrrd(head + "space directions: (1,0,0) (0,0,0) (0,0,1)\n") + "x");
  expect_clear_error(dir / "vec0.nrrd", {"space directions", "axis 1", "zero-length"});
  write_text(dir / "vecnan.nrrd", nrrd(head + "space directions: (1,0,0) (0,nan,0) (0,0,1)\n") + "x");
  expect_clear_error(dir / "vecnan.nrrd", {"space directions", "nan"});
  // nan (NRRD's "unknown") and none still read as 1.
  write_text(dir / "unknown.nrrd", nrrd(head + "space directions: (2,0,0) none (0,0,3)\n") + "x");
  EXPECT_EQ(open_volume(dir / "unknown.nrrd")->info().spacing, (Spacing{2, 1, 3}));
}

// The 352 bytes of a .nii written by our writer for a 2x2x2 u8 volume, with pixdim[axis] = v.
void write_nifti_with_pixdim(const fs::path& path, int axis, float v) {
  write_volume(path, Volume(Extent{2, 2, 2}, DType::u8));
  std::string bytes = read_text(path);
  std::memcpy(bytes.data() + 76 + 4 * axis, &v, sizeof v);
  write_text(path, bytes);
}

TEST(IoHostile, NiftiPixdimMustBePositiveOrZero) {
  test::TempDir dir;
  write_nifti_with_pixdim(dir / "neg.nii", 2, -1.5f);
  expect_clear_error(dir / "neg.nii", {"pixdim[2]", "-1.5", "positive"});
  write_nifti_with_pixdim(dir / "nan.nii", 1, std::numeric_limits<float>::quiet_NaN());
  expect_clear_error(dir / "nan.nii", {"pixdim[1]", "nan"});
  write_nifti_with_pixdim(dir / "inf.nii", 3, std::numeric_limits<float>::infinity());
  expect_clear_error(dir / "inf.nii", {"pixdim[3]", "inf"});
  // 0 is what many writers store for "unknown": it reads as 1.
  write_nifti_with_pixdim(dir / "zero.nii", 3, 0.0f);
  EXPECT_EQ(open_volume(dir / "zero.nii")->info().spacing, (Spacing{1, 1, 1}));
}

TEST(IoHostile, RawSpacingMustBePositive) {
  test::TempDir dir;
  write_text(dir / "s.raw", "x");
  for (const char* spacing : {"[1,0,1]", "[1,-1,1]", "[1,1e999,1]", "[1,\"2\",1]", "[1,1]", "null"}) {
    SCOPED_TRACE(spacing);
    write_text(dir / "s.raw.json", std::string(R"({"dims":[1,1,1],"dtype":"u8","spacing":)") + spacing + "}");
    if (std::string(spacing) == "[1,1e999,1]") {
      expect_clear_error(dir / "s.raw", {"s.raw.json", "json"});  // not valid JSON at all
      continue;
    }
    expect_clear_error(dir / "s.raw", {"s.raw.json", "spacing", "positive"});
  }
  fs::remove(dir / "s.raw.json");
  ReadOptions options;
  options.raw_dims = Extent{1, 1, 1};
  options.raw_dtype = DType::u8;
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    options.raw_spacing = Spacing{1, bad, 1};
    EXPECT_EQ(test::parameter_of([&] { open_volume(dir / "s.raw", options); }), "ReadOptions::raw_spacing");
  }
}

// ---------------------------------------------------------------------------------------------
// 13. messages, not library text

TEST(IoHostile, SidecarFieldsOfTheWrongTypeNameTheField) {
  test::TempDir dir;
  write_text(dir / "t.raw", std::string(8, 'x'));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"dims":["2","2","2"],"dtype":"u8"})", "dims"},
      {R"({"dims":[2.0,2,2],"dtype":"u8"})", "dims"},
      {R"({"dims":[18446744073709551615,2,2],"dtype":"u8"})", "dims"},
      {R"({"dims":{"x":2},"dtype":"u8"})", "dims"},
      {R"({"dims":[2,2,2],"dtype":8})", "dtype"},
      {R"({"dims":[2,2,2],"dtype":"u8","endian":1})", "endian"},
      {R"({"dims":[2,2,2],"dtype":"u8","header_bytes":-1})", "header_bytes"},
      {R"({"dims":[2,2,2],"dtype":"u8","header_bytes":1.5})", "header_bytes"},
      {R"({"dims":[2,2,2],"dtype":"u8","header_bytes":"0"})", "header_bytes"},
      {R"([2,2,2])", "json"},
  };
  for (const auto& [json, field] : cases) {
    SCOPED_TRACE(json);
    write_text(dir / "t.raw.json", json);
    expect_clear_error(dir / "t.raw", {"t.raw.json", field});
  }
  // A zero header_bytes is fine however it is spelt.
  write_text(dir / "t.raw.json", R"({"dims":[2,2,2],"dtype":"u8","header_bytes":0})");
  EXPECT_EQ(open_volume(dir / "t.raw")->info().dims, (Extent{2, 2, 2}));
}

TEST(IoHostile, EmptyFilesSayTheyAreEmpty) {
  test::TempDir dir;
  for (const char* name : {"e.nrrd", "e.nii", "e.nii.gz", "e.tif"}) {
    write_text(dir / name, "");
    expect_clear_error(dir / name, {"empty file (0 bytes)"});
  }
  write_text(dir / "e.strata", "");
  expect_clear_error(dir / "e.strata", {"empty file (0 bytes), expected a .strata container"});
  write_text(dir / "junk.strata", "not a container");
  expect_clear_error(dir / "junk.strata", {"not a .strata container"});
}

TEST(IoHostile, FoldersAndFifosAreNotMapped) {
  test::TempDir dir;
  fs::create_directory(dir / "folder.nii");
  expect_clear_error(dir / "folder.nii", {"folder"});
  ASSERT_EQ(::mkfifo((dir / "pipe.nii").c_str(), 0600), 0);
  expect_clear_error(dir / "pipe.nii", {"not a regular file"});  // returns at once, no writer needed
  write_text(dir / "d.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\ndata file: pipe.nii\n");
  expect_clear_error(dir / "d.nhdr", {"data file", "not a regular file"});
}

TEST(IoHostile, AbsurdNrrdHeaderValues) {
  test::TempDir dir;
  write_text(dir / "dim.nrrd", nrrd("type: uint8\ndimension: 4294967299\nsizes: 1 1 1\nencoding: raw\n") + "x");
  expect_clear_error(dir / "dim.nrrd", {"dimension", "4294967299"});
  write_text(dir / "ls.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n"
                                   "line skip: 9223372036854775807\n") + "x");
  expect_clear_error(dir / "ls.nrrd", {"line skip"});
  write_text(dir / "bs.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n"
                                   "byte skip: 9223372036854775807\n") + "x");
  expect_clear_error(dir / "bs.nrrd", {"data"});
  write_text(dir / "size.nrrd", nrrd("type: uint8\ndimension: 3\nsizes: 1 1 99999999999999999999\nencoding: raw\n"));
  expect_clear_error(dir / "size.nrrd", {"sizes"});
}

TEST(IoHostile, AbsurdNiftiVoxOffset) {
  test::TempDir dir;
  write_volume(dir / "v.nii", Volume(Extent{2, 2, 2}, DType::u8));
  std::string bytes = read_text(dir / "v.nii");
  const float huge = 3e38f;
  std::memcpy(bytes.data() + 108, &huge, sizeof huge);
  write_text(dir / "v.nii", bytes);
  expect_clear_error(dir / "v.nii", {"vox_offset"});
}

}  // namespace
}  // namespace strata::io
