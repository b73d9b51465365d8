// Cross-format chains through the public API: raw -> NRRD -> NIfTI -> TIFF -> raw must give
// back the starting bytes, dims and spacing, so no reader or writer may reorder, rescale or
// byte-swap samples differently from the others.
#include <gtest/gtest.h>

#include <algorithm>

#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata {
namespace {

namespace fs = std::filesystem;
using test::TempDir;
using namespace test::io;

class IoFormatChain : public ::testing::TestWithParam<DType> {};

TEST_P(IoFormatChain, RawNrrdNiftiTiffRawIsIdentity) {
  const DType dtype = GetParam();
  TempDir dir;
  // Spacings exactly representable in float32 (NIfTI stores pixdim as float).
  const Spacing spacing{0.5, 1.25, 3.0};
  const Volume start = random_volume({13, 6, 5}, dtype, 2024, spacing);

  io::ReadOptions raw_options;
  raw_options.raw_dims = start.dims();
  raw_options.raw_dtype = dtype;
  raw_options.raw_spacing = spacing;

  io::write_volume(dir / "start.raw", start);
  const Volume from_raw = io::read_volume(dir / "start.raw", raw_options);
  expect_same(from_raw, start, "raw");

  io::write_volume(dir / "a.nrrd", from_raw);
  const Volume from_nrrd = io::read_volume(dir / "a.nrrd");
  expect_same(from_nrrd, start, "nrrd");

  io::write_volume(dir / "b.nii.gz", from_nrrd);
  const Volume from_nifti = io::read_volume(dir / "b.nii.gz");
  expect_same(from_nifti, start, "nifti");

  io::write_volume(dir / "c.tif", from_nifti);
  const Volume from_tiff = io::read_volume(dir / "c.tif");
  expect_same(from_tiff, start, "tiff");

  io::write_volume(dir / "end.raw", from_tiff);
  expect_same(io::read_volume(dir / "end.raw", raw_options), start, "raw again");
}

INSTANTIATE_TEST_SUITE_P(TypesAllFormatsStore, IoFormatChain,
                         ::testing::Values(DType::u8, DType::u16, DType::i16, DType::u32, DType::i32, DType::f32,
                                           DType::f64),
                         [](const auto& info) { return std::string(dtype_name(info.param)); });

// The same chain through streaming copies, slab by slab, and a folder of TIFF slices.
TEST(IoFormatChain, StreamedThroughSlabsAndATiffFolder) {
  TempDir dir;
  const Volume start = random_volume({10, 9, 8}, DType::i16, 7, {1.0, 1.0, 2.5});
  io::write_volume(dir / "a.nii", start);
  auto copy = [](const fs::path& from, const fs::path& to, const io::WriteOptions& options) {
    auto source = io::open_volume(from);
    auto writer = io::create_volume_writer(to, source->info(), options);
    for (std::int64_t z = 0; z < source->info().dims.z; z += 3)
      writer->write_slab(source->read_slab(z, std::min(z + 3, source->info().dims.z)));
    writer->finish();
  };
  io::WriteOptions tiff_folder;
  tiff_folder.format = "tiff";
  copy(dir / "a.nii", dir / "slices", tiff_folder);
  copy(dir / "slices", dir / "b.nrrd", {});
  copy(dir / "b.nrrd", dir / "c.nii.gz", {});
  expect_same(io::read_volume(dir / "c.nii.gz"), start, "nii -> tiff folder -> nrrd -> nii.gz");
}

}  // namespace
}  // namespace strata
