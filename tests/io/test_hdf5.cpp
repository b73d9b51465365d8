// HDF5 volumes: what the writer stores reads back (every sample type, voxel size, placement),
// files built here with the HDF5 C API read as their layout says (chunked with shuffle and
// deflate, contiguous, big-endian, 4-D, several datasets, a user block, 64-bit ids), and
// datasets that are not volumes are refused naming the file and the field.
#include <hdf5.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <thread>
#include <vector>

#include "io/io_test_util.hpp"
#include "strata/core/error.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// A file built with the C API for a test; closed (and complete) when the object dies.
class H5Builder {
 public:
  explicit H5Builder(const fs::path& path, hsize_t user_block = 0) {
    const hid_t creation = H5Pcreate(H5P_FILE_CREATE);
    if (user_block) H5Pset_userblock(creation, user_block);
    file_ = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, creation, H5P_DEFAULT);
    H5Pclose(creation);
    EXPECT_GE(file_, 0);
  }
  ~H5Builder() {
    for (hid_t d : datasets_) H5Dclose(d);
    H5Fclose(file_);
  }

  // Dataset `name` of `shape` (C order) stored as `file_type`, filled from `data` (`memory_type`).
  hid_t add(const char* name, hid_t file_type, const std::vector<hsize_t>& shape, hid_t memory_type, const void* data,
            hid_t creation = H5P_DEFAULT) {
    const hid_t links = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(links, 1);
    const hid_t space = H5Screate_simple(int(shape.size()), shape.data(), nullptr);
    const hid_t dataset = H5Dcreate2(file_, name, file_type, space, links, creation, H5P_DEFAULT);
    EXPECT_GE(dataset, 0) << name;
    if (data) {
      EXPECT_GE(H5Dwrite(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0);
    }
    H5Sclose(space);
    H5Pclose(links);
    datasets_.push_back(dataset);
    return dataset;
  }

  H5Builder(const H5Builder&) = delete;
  H5Builder& operator=(const H5Builder&) = delete;

 private:
  hid_t file_ = H5I_INVALID_HID;
  std::vector<hid_t> datasets_;
};

void attribute(hid_t dataset, const char* name, hid_t file_type, std::vector<double> values) {
  const hsize_t n = values.size();
  const hid_t space = H5Screate_simple(1, &n, nullptr);
  const hid_t a = H5Acreate2(dataset, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(a, H5T_NATIVE_DOUBLE, values.data());
  H5Aclose(a);
  H5Sclose(space);
}

hid_t chunked(std::vector<hsize_t> chunk, bool shuffle, int deflate) {
  const hid_t creation = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(creation, int(chunk.size()), chunk.data());
  if (shuffle) H5Pset_shuffle(creation);
  if (deflate >= 0) H5Pset_deflate(creation, unsigned(deflate));
  return creation;
}

template <class T>
std::vector<T> iota_values(std::size_t n, T first = T(0)) {
  std::vector<T> v(n);
  std::iota(v.begin(), v.end(), first);
  return v;
}

ReadOptions dataset_named(std::string name) {
  ReadOptions options;
  options.dataset = std::move(name);
  return options;
}

ReadOptions volume_number(std::int64_t volume) {
  ReadOptions options;
  options.volume = volume;
  return options;
}

// Runs `f`, expects a FormatError whose text holds the file name, `field` and `hint`.
template <class F>
void expect_refused(F&& f, const fs::path& file, const std::string& field, const std::string& hint) {
  try {
    f();
    ADD_FAILURE() << "accepted";
  } catch (const FormatError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find(field), std::string::npos) << what;
    EXPECT_NE(what.find(hint), std::string::npos) << what;
  }
}

VolumeInfo placed_info(Extent dims, DType dtype) {
  VolumeInfo info{.dims = dims, .dtype = dtype, .spacing = {0.5, 1.25, 2.0}};
  info.geometry.origin = {10.0, -20.5, 3.25};
  info.geometry.direction = {{{0.0, -1.0, 0.0}, {1.0, 0.0, 0.0}, {0.0, 0.0, 1.0}}};
  info.geometry.unit = "mm";
  info.geometry.space = WorldSpace::lps;
  return info;
}

TEST(IoHdf5, EveryDtypeRoundTripsWithItsGeometry) {
  TempDir dir;
  for (DType dtype : kAllDTypes) {
    const fs::path path = dir / (std::string(dtype_name(dtype)) + ".h5");
    // 70 columns: a full 64-wide chunk and a clipped one; slabs of 2 slices cross chunk rows.
    Volume v = test::io::random_volume({70, 9, 5}, dtype, 7);
    const VolumeInfo info = placed_info(v.dims(), dtype);
    auto writer = create_volume_writer(path, info);
    for (std::int64_t z = 0; z < 5; z += 2) writer->write_slab(v.crop({{0, 0, z}, {70, 9, std::min<std::int64_t>(z + 2, 5)}}));
    writer->finish();
    auto source = open_volume(path);
    EXPECT_EQ(source->info().dtype, dtype);
    EXPECT_EQ(source->info().dims, v.dims());
    EXPECT_EQ(source->info().spacing, info.spacing);
    EXPECT_EQ(source->info().geometry, info.geometry);
    const Volume back = source->read_all();
    ASSERT_EQ(std::memcmp(back.bytes(), v.bytes(), v.byte_size()), 0) << dtype_name(dtype);
    const Box box{{3, 2, 1}, {66, 8, 4}};
    const Volume part = source->read_box(box);
    const Volume expected = v.crop(box);
    EXPECT_EQ(std::memcmp(part.bytes(), expected.bytes(), expected.byte_size()), 0) << dtype_name(dtype);
  }
}

TEST(IoHdf5, WriterStoresChunkedDeflateAndFijiVoxelSize) {
  TempDir dir;
  const Volume v = test::io::random_volume({80, 70, 3}, DType::u16, 3);
  write_volume(dir / "packed.h5", v, {});
  {
    VolumeInfo info = placed_info(v.dims(), DType::u16);
    WriteOptions uncompressed;
    uncompressed.compress = false;
    auto writer = create_volume_writer(dir / "plain.h5", info, uncompressed);
    writer->write_slab(v);
    writer->finish();
  }
  const hid_t file = H5Fopen((dir / "packed.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t dataset = H5Dopen2(file, "/volume", H5P_DEFAULT);
  ASSERT_GE(dataset, 0);
  hid_t creation = H5Dget_create_plist(dataset);
  std::array<hsize_t, 3> chunk{};
  EXPECT_EQ(H5Pget_layout(creation), H5D_CHUNKED);
  H5Pget_chunk(creation, 3, chunk.data());
  EXPECT_EQ(chunk, (std::array<hsize_t, 3>{3, 64, 64}));
  ASSERT_EQ(H5Pget_nfilters(creation), 2);
  EXPECT_EQ(H5Pget_filter2(creation, 0, nullptr, nullptr, nullptr, 0, nullptr, nullptr), H5Z_FILTER_SHUFFLE);
  EXPECT_EQ(H5Pget_filter2(creation, 1, nullptr, nullptr, nullptr, 0, nullptr, nullptr), H5Z_FILTER_DEFLATE);
  H5Pclose(creation);
  H5Dclose(dataset);
  H5Fclose(file);

  const hid_t plain = H5Fopen((dir / "plain.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t plain_set = H5Dopen2(plain, "/volume", H5P_DEFAULT);
  creation = H5Dget_create_plist(plain_set);
  EXPECT_EQ(H5Pget_nfilters(creation), 0);
  H5Pclose(creation);
  // The voxel size in micrometres, z first, as Fiji reads it: 2 mm, 1.25 mm, 0.5 mm.
  const hid_t a = H5Aopen(plain_set, "element_size_um", H5P_DEFAULT);
  std::array<double, 3> um{};
  H5Aread(a, H5T_NATIVE_DOUBLE, um.data());
  EXPECT_EQ(um, (std::array<double, 3>{2000.0, 1250.0, 500.0}));
  H5Aclose(a);
  H5Dclose(plain_set);
  H5Fclose(plain);
  EXPECT_FALSE(fs::exists(dir / "plain.h5.tmp"));
}

TEST(IoHdf5, WritesAndReadsANamedDatasetInAGroup) {
  TempDir dir;
  const Volume v = test::io::random_volume({6, 5, 4}, DType::i16, 5);
  write_volume(dir.path().string() + "/out.h5:/scan/recon", v);
  ASSERT_TRUE(fs::exists(dir / "out.h5"));
  const Volume back = read_volume(dir.path().string() + "/out.h5:/scan/recon");
  EXPECT_EQ(std::memcmp(back.bytes(), v.bytes(), v.byte_size()), 0);
  // Without a name the only volume dataset is found wherever it is.
  EXPECT_EQ(open_volume(dir / "out.h5")->info().dims, v.dims());
  EXPECT_THROW(write_volume(dir.path().string() + "/out.nrrd:/x", v), Error);
}

TEST(IoHdf5, ReadsChunkedShuffledDeflatedBoxes) {
  TempDir dir;
  const fs::path path = dir / "chunked.h5";
  const std::vector<std::uint16_t> values = iota_values<std::uint16_t>(7 * 9 * 11, 1000);
  {
    H5Builder b(path);
    const hid_t creation = chunked({3, 4, 5}, true, 6);
    b.add("/data", H5T_STD_U16LE, {7, 9, 11}, H5T_NATIVE_UINT16, values.data(), creation);
    H5Pclose(creation);
  }
  auto source = open_volume(path);
  EXPECT_EQ(source->info().dims, (Extent{11, 9, 7}));
  const Box box{{2, 3, 1}, {10, 8, 6}};
  const Volume part = source->read_box(box);
  auto s = part.samples<std::uint16_t>();
  std::size_t i = 0;
  for (std::int64_t z = 1; z < 6; ++z)
    for (std::int64_t y = 3; y < 8; ++y)
      for (std::int64_t x = 2; x < 10; ++x) ASSERT_EQ(s[i++], values[std::size_t((z * 9 + y) * 11 + x)]);
}

TEST(IoHdf5, ReadsContiguousBigEndianSamples) {
  TempDir dir;
  const fs::path path = dir / "big.hdf5";
  const std::vector<std::int32_t> ints = iota_values<std::int32_t>(4 * 3 * 2, -100000);
  const std::vector<double> reals = {1.5, -2.25, 1e300, -0.0, 3, 4, 5, 6};
  {
    H5Builder b(path);
    b.add("/ints", H5T_STD_I32BE, {2, 3, 4}, H5T_NATIVE_INT32, ints.data());
    b.add("/reals", H5T_IEEE_F64BE, {2, 2, 2}, H5T_NATIVE_DOUBLE, reals.data());
  }
  const Volume i = read_volume(path, dataset_named("/ints"));
  EXPECT_EQ(i.dtype(), DType::i32);
  EXPECT_TRUE(std::equal(ints.begin(), ints.end(), i.samples<std::int32_t>().begin()));
  const Volume r = read_volume(path, dataset_named("reals"));
  EXPECT_EQ(r.dtype(), DType::f64);
  EXPECT_TRUE(std::equal(reals.begin(), reals.end(), r.samples<double>().begin()));
}

TEST(IoHdf5, LeadingAxesOfFourAndFiveDimensionsAreVolumes) {
  TempDir dir;
  const fs::path path = dir / "series.h5";
  const std::vector<float> values = iota_values<float>(2 * 3 * 2 * 3 * 4);
  {
    H5Builder b(path);
    b.add("/tczyx", H5T_IEEE_F32LE, {2, 3, 2, 3, 4}, H5T_NATIVE_FLOAT, values.data());
  }
  expect_refused([&] { (void)open_volume(path); }, path, "shape", "--volume");
  auto source = open_volume(path, volume_number(4));  // t = 1, c = 1
  EXPECT_EQ(source->info().volumes, 6);
  EXPECT_EQ(source->info().dims, (Extent{4, 3, 2}));
  const Volume v = source->read_all();
  const std::size_t first = 4 * 24;
  EXPECT_TRUE(std::equal(v.samples<float>().begin(), v.samples<float>().end(), values.begin() + first));
  EXPECT_THROW((void)open_volume(path, volume_number(6)), ParameterError);
}

TEST(IoHdf5, SeveralDatasetsAreListedForTheUserToPick) {
  TempDir dir;
  const fs::path path = dir / "two.h5";
  const std::vector<std::uint8_t> bytes(2 * 2 * 2, 7);
  {
    H5Builder b(path);
    b.add("/entry/raw", H5T_STD_U8LE, {2, 2, 2}, H5T_NATIVE_UINT8, bytes.data());
    b.add("/entry/recon", H5T_STD_U8LE, {2, 2, 2}, H5T_NATIVE_UINT8, bytes.data());
    b.add("/angles", H5T_IEEE_F64LE, {3}, H5T_NATIVE_DOUBLE, nullptr);
  }
  expect_refused([&] { (void)open_volume(path); }, path, "dataset", "/entry/raw (2, 2, 2) u8, /entry/recon (2, 2, 2) u8");
  EXPECT_EQ(open_volume(path.string() + ":/entry/recon")->info().dims, (Extent{2, 2, 2}));
  expect_refused([&] { (void)open_volume(path, dataset_named("/entry/missing")); }, path, "dataset",
                 "no dataset '/entry/missing'");
  expect_refused([&] { (void)open_volume(path, dataset_named("/entry")); }, path, "dataset", "is a group");
}

TEST(IoHdf5, SixtyFourBitIdsAboveTwoToTheFortyAreExact) {
  TempDir dir;
  const fs::path path = dir / "labels.h5";
  std::vector<std::uint64_t> ids(4 * 4 * 4);
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = (std::uint64_t(1) << 40) + i * 0x100000001ULL;
  {
    H5Builder b(path);
    const hid_t creation = chunked({2, 2, 2}, true, 1);
    b.add("/seg", H5T_STD_U64LE, {4, 4, 4}, H5T_NATIVE_UINT64, ids.data(), creation);
    H5Pclose(creation);
  }
  const Volume v = read_volume(path);
  EXPECT_EQ(v.dtype(), DType::u64);
  EXPECT_TRUE(std::equal(ids.begin(), ids.end(), v.samples<std::uint64_t>().begin()));
  write_volume(dir / "copy.h5", v);
  const Volume copy = read_volume(dir / "copy.h5");
  EXPECT_TRUE(std::equal(ids.begin(), ids.end(), copy.samples<std::uint64_t>().begin()));
}

TEST(IoHdf5, VoxelSizeFromElementSizeUmAndSignatureAfterAUserBlock) {
  TempDir dir;
  const fs::path path = dir / "ilastik.data";  // no registered extension: found by its signature at 512
  const std::vector<std::uint8_t> bytes(2 * 3 * 4, 1);
  {
    H5Builder b(path, 512);
    const hid_t d = b.add("/exported_data", H5T_STD_U8LE, {2, 3, 4}, H5T_NATIVE_UINT8, bytes.data());
    attribute(d, "element_size_um", H5T_IEEE_F32LE, {2.0, 0.5, 0.25});
  }
  EXPECT_EQ(detect_format(path).name, "hdf5");
  const auto source = open_volume(path);
  EXPECT_EQ(source->info().spacing, (Spacing{0.25, 0.5, 2.0}));
  EXPECT_EQ(source->info().geometry.unit, "um");
}

TEST(IoHdf5, BoxesReadFromSeveralThreadsAtOnce) {
  TempDir dir;
  const Volume v = test::io::random_volume({40, 30, 20}, DType::f32, 11);
  write_volume(dir / "shared.h5", v);
  auto source = open_volume(dir / "shared.h5");
  std::vector<std::thread> threads;
  std::vector<int> mismatches(4, 0);
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (std::int64_t z = t; z < 20; z += 4) {
        const Volume slice = source->read_slab(z, z + 1);
        const Volume expected = v.crop({{0, 0, z}, {40, 30, z + 1}});
        mismatches[std::size_t(t)] += std::memcmp(slice.bytes(), expected.bytes(), expected.byte_size()) != 0;
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(mismatches, std::vector<int>(4, 0));
}

TEST(IoHdf5, DatasetsThatAreNotVolumesAreRefused) {
  TempDir dir;
  const fs::path path = dir / "hostile.h5";
  {
    H5Builder b(path);
    b.add("/line", H5T_STD_U8LE, {5}, H5T_NATIVE_UINT8, nullptr);
    b.add("/six", H5T_STD_U8LE, {1, 1, 1, 1, 1, 2}, H5T_NATIVE_UINT8, nullptr);
    const hid_t text = H5Tcopy(H5T_C_S1);
    H5Tset_size(text, 8);
    b.add("/names", text, {2, 2, 2}, text, nullptr);
    H5Tclose(text);
    // 2^21 cubed u64 samples: 2^66 bytes, more than any file offset.
    const hid_t creation = chunked({1, 1, 1}, false, -1);
    b.add("/huge", H5T_STD_U64LE, {hsize_t(1) << 21, hsize_t(1) << 21, hsize_t(1) << 21}, H5T_NATIVE_UINT64, nullptr,
          creation);
    H5Pclose(creation);
    const hid_t bad = b.add("/bad_spacing", H5T_STD_U8LE, {1, 1, 1}, H5T_NATIVE_UINT8, nullptr);
    attribute(bad, "spacing", H5T_IEEE_F64LE, {1.0, 2.0});
    const hid_t negative = b.add("/negative_spacing", H5T_STD_U8LE, {1, 1, 1}, H5T_NATIVE_UINT8, nullptr);
    attribute(negative, "element_size_um", H5T_IEEE_F64LE, {1.0, -2.0, 1.0});
  }
  expect_refused([&] { (void)open_volume(path, dataset_named("/line")); }, path, "rank", "1 dimensions");
  expect_refused([&] { (void)open_volume(path, dataset_named("/six")); }, path, "rank", "6 dimensions");
  expect_refused([&] { (void)open_volume(path, dataset_named("/names")); }, path, "type", "string");
  expect_refused([&] { (void)open_volume(path, dataset_named("/huge")); }, path, "shape", "");
  expect_refused([&] { (void)open_volume(path, dataset_named("/bad_spacing")); }, path, "attribute spacing", "2 values");
  expect_refused([&] { (void)open_volume(path, dataset_named("/negative_spacing")); }, path, "attribute element_size_um",
                 "not positive");
  // Several volume-shaped datasets: the listing names each with its shape and type.
  expect_refused([&] { (void)open_volume(path); }, path, "dataset", "/names (2, 2, 2) string");
}

// Scale-offset (lossless at minimum bits 0 for integers) decodes only from a chunk of full size:
// first in the pipeline, or after shuffle. After deflate libhdf5 reads past the chunk's end.
TEST(IoHdf5, ScaleOffsetIsReadFirstInThePipelineAndRefusedAfterDeflate) {
  TempDir dir;
  const std::vector<std::uint64_t> values = iota_values<std::uint64_t>(4 * 5 * 6, std::uint64_t(1) << 50);
  const fs::path good = dir / "scale_offset_first.h5", bad = dir / "scale_offset_after_deflate.h5";
  {
    H5Builder b(good);
    const hid_t creation = chunked({4, 5, 6}, true, -1);
    H5Pset_scaleoffset(creation, H5Z_SO_INT, H5Z_SO_INT_MINBITS_DEFAULT);
    H5Pset_deflate(creation, 4);
    b.add("/data", H5T_STD_U64LE, {4, 5, 6}, H5T_NATIVE_UINT64, values.data(), creation);
    H5Pclose(creation);
  }
  const Volume read = read_volume(good);
  const auto samples = read.samples<std::uint64_t>();
  EXPECT_TRUE(std::equal(samples.begin(), samples.end(), values.begin(), values.end()));
  {
    H5Builder b(bad);
    // Created without samples: writing through this pipeline already overruns libhdf5's heap.
    const hid_t creation = chunked({4, 5, 6}, false, 4);
    H5Pset_scaleoffset(creation, H5Z_SO_INT, H5Z_SO_INT_MINBITS_DEFAULT);
    b.add("/data", H5T_STD_U64LE, {4, 5, 6}, H5T_NATIVE_UINT64, nullptr, creation);
    H5Pclose(creation);
  }
  expect_refused([&] { (void)open_volume(bad); }, bad, "filter", "scale-offset after filter 1 ('deflate')");
}

// A filter the library does not have (a plugin's, here one registered only while writing).
int pass_through_calls = 0;
std::size_t pass_through(unsigned, std::size_t, const unsigned[], std::size_t bytes, std::size_t*, void**) {
  ++pass_through_calls;
  return bytes;
}

TEST(IoHdf5, AFilterTheLibraryLacksIsNamed) {
  TempDir dir;
  const fs::path path = dir / "plugin.h5";
  constexpr H5Z_filter_t kId = 40123;
  const H5Z_class2_t filter{H5Z_CLASS_T_VERS, kId, 1, 1, "test pass-through", nullptr, nullptr, pass_through};
  ASSERT_GE(H5Zregister(&filter), 0);
  const std::vector<std::uint8_t> bytes(8, 3);
  {
    H5Builder b(path);
    const hid_t creation = chunked({2, 2, 2}, false, -1);
    H5Pset_filter(creation, kId, H5Z_FLAG_MANDATORY, 0, nullptr);
    b.add("/data", H5T_STD_U8LE, {2, 2, 2}, H5T_NATIVE_UINT8, bytes.data(), creation);
    H5Pclose(creation);
  }
  ASSERT_GE(H5Zunregister(kId), 0);
  expect_refused([&] { (void)open_volume(path); }, path, "filter", "40123");
}

}  // namespace
}  // namespace strata::io
