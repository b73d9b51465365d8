// Streaming: memory stays bounded while reading slab by slab, gzip inputs decode to a
// temporary that disappears with the source, writers check their slabs, atomic output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>

#include "io/io_detail.hpp"
#include "io/io_test_util.hpp"
#include "strata/io/files.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

using namespace strata::test::io;

// Sample value of voxel (x, y, z) of the patterned test volume: every slice distinct.
std::uint16_t pattern(std::int64_t x, std::int64_t y, std::int64_t z) {
  return std::uint16_t((x * 7 + y * 13 + z * 101) & 0xffff);
}

Volume pattern_slab(const Extent& dims, std::int64_t z0, std::int64_t z1) {
  Volume slab(Extent{dims.x, dims.y, z1 - z0}, DType::u16);
  auto v = slab.view<std::uint16_t>();
  for (std::int64_t z = z0; z < z1; ++z)
    for (std::int64_t y = 0; y < dims.y; ++y)
      for (std::int64_t x = 0; x < dims.x; ++x) v(x, y, z - z0) = pattern(x, y, z);
  return slab;
}

// Resident pages of memory-mapped files in this process (kB -> bytes). Counting only file
// pages keeps the measure independent of the heap (and of a sanitizer's quarantine).
std::int64_t resident_bytes() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("RssFile:", 0) == 0) return std::stoll(line.substr(8)) * 1024;
  ADD_FAILURE() << "/proc/self/status has no RssFile line";
  return 0;
}

void write_pattern_volume(const std::filesystem::path& path, const Extent& dims, std::int64_t slab_slices,
                          const WriteOptions& options = {}) {
  auto writer = create_volume_writer(path, VolumeInfo{dims, DType::u16, {}}, options);
  for (std::int64_t z = 0; z < dims.z; z += slab_slices)
    writer->write_slab(pattern_slab(dims, z, std::min(dims.z, z + slab_slices)));
  writer->finish();
}

// Streams all slabs, checks their contents and returns the largest RSS growth seen.
std::int64_t stream_and_measure(VolumeSource& source, std::int64_t slab_slices) {
  const Extent dims = source.info().dims;
  const std::int64_t baseline = resident_bytes();
  std::int64_t peak = 0;
  for (std::int64_t z = 0; z < dims.z; z += slab_slices) {
    const std::int64_t z1 = std::min(dims.z, z + slab_slices);
    Volume slab = source.read_slab(z, z1);
    EXPECT_TRUE(slab == pattern_slab(dims, z, z1)) << "slab at z " << z;
    peak = std::max(peak, resident_bytes() - baseline);
  }
  return peak;
}

// 96 MiB of samples read in 4 MiB slabs: without releasing consumed pages the mapped file
// would add the whole 96 MiB to the resident set (the acceptance test streams 1 GiB the same way).
TEST(IoStreaming, SlabReadsKeepResidentMemorySmall) {
  test::TempDir dir;
  const Extent dims{1024, 1024, 48};
  write_pattern_volume(dir / "big.raw", dims, 8);
  auto source = open_volume(dir / "big.raw");
  const std::int64_t growth = stream_and_measure(*source, 2);
  EXPECT_LT(growth, 16ll << 20) << "resident set grew by " << (growth >> 20) << " MiB";
}

TEST(IoStreaming, GzipNrrdSlabReadsKeepResidentMemorySmall) {
  test::TempDir dir;
  const Extent dims{1024, 1024, 48};
  write_pattern_volume(dir / "big.nrrd", dims, 8);
  ReadOptions options;
  options.temp_dir = dir.path();
  auto source = open_volume(dir / "big.nrrd", options);
  const std::int64_t growth = stream_and_measure(*source, 2);
  EXPECT_LT(growth, 16ll << 20) << "resident set grew by " << (growth >> 20) << " MiB";
}

// Random access to a gzip input (a step back) decodes it once to an unnamed temporary.
TEST(IoStreaming, GzipInputDecodesToATemporaryThatDiesWithTheSource) {
  test::TempDir dir, scratch;
  const Extent dims{64, 48, 40};
  write_pattern_volume(dir / "g.nrrd", dims, 7);
  CountingProgress progress;
  ReadOptions options;
  options.temp_dir = scratch.path();
  options.progress = &progress;
  {
    auto source = open_volume(dir / "g.nrrd", options);
    EXPECT_TRUE(source->read_slab(10, 30) == pattern_slab(dims, 10, 30));  // streamed: no temporary
    EXPECT_FALSE(maps_a_file_in(scratch.path()));
    // A step back: the decoded samples live in temp_dir, in a file without a name that no kill
    // can leave behind.
    EXPECT_TRUE(source->read_slab(5, 8) == pattern_slab(dims, 5, 8));
    EXPECT_TRUE(maps_a_file_in(scratch.path()));
    EXPECT_EQ(file_count(scratch.path()), 0u);
    EXPECT_EQ(source->path(), dir / "g.nrrd");
  }
  EXPECT_EQ(file_count(scratch.path()), 0u);
  EXPECT_FALSE(maps_a_file_in(scratch.path()));  // and the space is freed with the source
  // Progress counts the decoded bytes of the volume.
  EXPECT_EQ(progress.begins, 1);
  EXPECT_EQ(progress.ends, 1);
  EXPECT_EQ(progress.total, std::uint64_t(dims.voxel_count()) * 2);
  EXPECT_EQ(progress.advanced, progress.total);
}

TEST(IoStreaming, SlabsOfAnySizeWriteTheSameVolume) {
  test::TempDir dir;
  const Extent dims{33, 17, 23};
  write_pattern_volume(dir / "one.nrrd", dims, 23);
  write_pattern_volume(dir / "many.nrrd", dims, 3);
  Volume expected = pattern_slab(dims, 0, dims.z);
  EXPECT_TRUE(read_volume(dir / "one.nrrd") == expected);
  EXPECT_TRUE(read_volume(dir / "many.nrrd") == expected);
}

TEST(IoStreaming, WriterRejectsMismatchedSlabs) {
  test::TempDir dir;
  const Extent dims{8, 6, 5};
  for (const char* name : {"w.raw", "w.nrrd"}) {
    SCOPED_TRACE(name);
    auto writer = create_volume_writer(dir / name, VolumeInfo{dims, DType::u16, {}});
    EXPECT_THROW(writer->write_slab(Volume(Extent{8, 5, 1}, DType::u16)), Error);  // wrong y
    EXPECT_THROW(writer->write_slab(Volume(Extent{7, 6, 1}, DType::u16)), Error);  // wrong x
    EXPECT_THROW(writer->write_slab(Volume(Extent{8, 6, 1}, DType::i16)), Error);  // wrong dtype
    EXPECT_THROW(writer->write_slab(Volume(Extent{8, 6, 6}, DType::u16)), Error);  // too many slices
    writer->write_slab(pattern_slab(dims, 0, 2));
    try {
      writer->finish();
      FAIL() << "finish() after 2 of 5 slices must fail";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("wrote 2 slices, expected 5"), std::string::npos) << e.what();
    }
    writer.reset();
    EXPECT_EQ(file_count(dir.path()), 0u) << "an unfinished writer leaves nothing behind";
  }
}

TEST(IoStreaming, AtomicOutputFileRenamesOnCommitAndCleansUpOtherwise) {
  test::TempDir dir;
  {
    AtomicOutputFile out(dir / "kept.bin");
    out.write("abc", 3);
    EXPECT_TRUE(std::filesystem::exists(dir / "kept.bin.tmp"));
    EXPECT_FALSE(std::filesystem::exists(dir / "kept.bin"));
    out.commit();
  }
  EXPECT_EQ(read_text(dir / "kept.bin"), "abc");
  {
    AtomicOutputFile out(dir / "dropped.bin");
    out.write("xyz", 3);
  }
  EXPECT_EQ(file_count(dir.path()), 1u);
}

std::string gzip_with_our_writer(const std::filesystem::path& path, const std::string& payload) {
  write_gzipped(path, payload.data(), payload.size());
  return read_text(path);
}

TEST(IoStreaming, GzipRoundTripsLargeAndConcatenatedStreams) {
  test::TempDir dir;
  // Several MiB of poorly compressible bytes make the decoder fill its output buffer many times.
  std::string payload(5'000'000, '\0');
  std::uint64_t s = 99;
  for (auto& c : payload) {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    c = char(s >> 59);
  }
  const std::string first = gzip_with_our_writer(dir / "a.gz", payload);
  const std::string second = gzip_with_our_writer(dir / "b.gz", "tail");
  const std::string both = first + second;
  auto decoded = detail::gunzip_to_memory(reinterpret_cast<const std::byte*>(both.data()), both.size(), "both.gz",
                                          "data");
  ASSERT_EQ(decoded.size(), payload.size() + 4);
  EXPECT_EQ(std::memcmp(decoded.data(), payload.data(), payload.size()), 0);
  EXPECT_EQ(std::memcmp(decoded.data() + payload.size(), "tail", 4), 0);

  CountingProgress progress;
  ReadOptions options;
  options.temp_dir = dir.path();
  options.progress = &progress;
  auto mapped = detail::gunzip_to_temp_file(reinterpret_cast<const std::byte*>(both.data()), both.size(), options,
                                            "out", "both.gz", "data", {payload.size() + 4, "the test"});
  ASSERT_EQ(mapped->size(), payload.size() + 4);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(mapped->data()), mapped->size()), payload + "tail");
  EXPECT_EQ(progress.advanced, both.size());
}

TEST(IoStreaming, ByteSwapReversesEachSample) {
  unsigned char data[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  detail::byte_swap(reinterpret_cast<std::byte*>(data), 2, 4);
  const unsigned char expected[8] = {4, 3, 2, 1, 8, 7, 6, 5};
  EXPECT_EQ(std::memcmp(data, expected, 8), 0);
  detail::byte_swap(reinterpret_cast<std::byte*>(data), 1, 8);
  const unsigned char expected64[8] = {5, 6, 7, 8, 1, 2, 3, 4};
  EXPECT_EQ(std::memcmp(data, expected64, 8), 0);
}

TEST(IoVolumeIo, DetectsFormatsByName) {
  test::TempDir dir;
  EXPECT_EQ(detect_format("a.raw").name, "raw");
  EXPECT_EQ(detect_format("a.BIN").name, "raw");
  EXPECT_EQ(detect_format("a.nrrd").name, "nrrd");
  EXPECT_EQ(detect_format("a.nhdr").name, "nrrd");
  EXPECT_EQ(detect_format("a.nii").name, "nifti");
  EXPECT_EQ(detect_format("dir/a.nii.gz").name, "nifti");
  EXPECT_EQ(detect_format("a.tif").name, "tiff");
  EXPECT_EQ(detect_format("a.tiff").name, "tiff");
  EXPECT_EQ(detect_format(dir.path()).name, "tiff");
  EXPECT_THROW(detect_format("a.gz"), Error);
  EXPECT_THROW(detect_format("volume"), Error);
}

TEST(IoVolumeIo, FormatSupportsDtypes) {
  for (DType t : kAllDtypes) {
    EXPECT_TRUE(find_format("raw")->writes(t));
    EXPECT_TRUE(find_format("nrrd")->writes(t));
    EXPECT_TRUE(find_format("tiff")->writes(t));
    EXPECT_EQ(find_format("nifti")->writes(t), t != DType::i8);
  }
  test::TempDir dir;
  EXPECT_THROW(create_volume_writer(dir / "x.nii", VolumeInfo{{2, 2, 2}, DType::i8, {}}), Error);
}

TEST(IoVolumeIo, FormatOptionOverridesTheExtension) {
  test::TempDir dir;
  Volume v = pattern_slab({4, 3, 2}, 0, 2);
  WriteOptions options;
  options.format = "nrrd";
  write_volume(dir / "vol.dat", v, options);
  EXPECT_EQ(read_text(dir / "vol.dat").rfind("NRRD0004\n", 0), 0u);
}

}  // namespace
}  // namespace strata::io
