// What the compressor takes and what it refuses: magnitudes a float Tucker core cannot hold are
// refused up front with the file named (not a decomposition failure half-way), a range too small
// for the fixed-rank quantizer is refused with the mode that handles it, that mode meets its
// target on it, and no volume, however thin, costs more than its bricks stored losslessly.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "strata/core/metrics.hpp"
#include "ta/ta_test_util.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;

namespace {

// A smooth field in [-1, 1] with some noise, scaled and shifted.
Volume field(Extent dims, DType dtype, double scale, double offset) {
  Volume v(dims, dtype);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (std::int64_t z = 0; z < dims.z; ++z)
    for (std::int64_t y = 0; y < dims.y; ++y)
      for (std::int64_t x = 0; x < dims.x; ++x) {
        const double s = std::sin(0.2 * double(x)) * std::cos(0.15 * double(y)) * 0.9 + noise(rng) * 0.1 +
                         0.05 * std::sin(0.3 * double(z));
        v.set_value(x, y, z, offset + scale * s);
      }
  return v;
}

Volume uniform_integers(Extent dims, DType dtype, int hi, unsigned seed) {
  Volume v(dims, dtype);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(0, hi);
  for (std::int64_t z = 0; z < dims.z; ++z)
    for (std::int64_t y = 0; y < dims.y; ++y)
      for (std::int64_t x = 0; x < dims.x; ++x) v.set_value(x, y, z, d(rng));
  return v;
}

CompressParams fixed_rank() {
  CompressParams p = params(32, 2, 16, "u16,b8log+");
  p.codec.lossless_fallback = true;  // the default
  return p;
}
CompressParams psnr(double db) {
  CompressParams p = fixed_rank();
  p.codec.target = {TargetKind::psnr, db};
  return p;
}

std::string compress_error(const Volume& v, const CompressParams& p, const test::TempDir& dir) {
  MemorySource source(v, "sample.nrrd");
  return error_of([&] { compress_volume(source, dir.path() / "out.strata", p, silent_progress()); });
}

double bits_per_voxel(const CompressReport& r) { return 8.0 * double(r.file_bytes) / double(r.input_voxels); }

}  // namespace

TEST(TaCodableRange, MagnitudesBeyondAFloatCoreAreRefusedNamingTheFile) {
  const test::TempDir dir;
  // Brick 32: a core holds up to 32^1.5 = 181 times the largest sample; the limit keeps a
  // factor 2 of float range in reserve: 3.4e38 / 362 = 9.4e35.
  const double limit = double(std::numeric_limits<float>::max()) / (2.0 * std::pow(32.0, 1.5));
  for (const CompressParams& p : {fixed_rank(), psnr(40)}) {
    for (const auto& [dtype, scale] : {std::pair{DType::f32, 3e38}, std::pair{DType::f64, 1e300}}) {
      const std::string message = compress_error(field({40, 36, 34}, dtype, scale, 0), p, dir);
      EXPECT_TRUE(contains(message, "sample.nrrd: samples: the largest magnitude")) << message;
      EXPECT_TRUE(contains(message, "rescale")) << message;
    }
    // Just inside the limit, every mode compresses and decodes to finite samples near the input.
    const Volume near_limit = field({40, 36, 34}, DType::f32, 0.9 * limit, 0);
    compress(near_limit, dir.path() / "near.strata", p);
    const TaVolume t(dir.path() / "near.strata");
    const ErrorMetrics e = compare_volumes(as_f32(near_limit), t.decode_box(0, Box::whole(near_limit.dims()), t.rank()));
    EXPECT_TRUE(std::isfinite(e.rmse));
    EXPECT_GT(e.psnr_db, 25.0);
  }
}

TEST(TaCodableRange, ATinyRangeOnALargeOffsetIsRefusedByTheFixedRankModeAndMetByATarget) {
  const test::TempDir dir;
  // 2e-7 around 1.0: a few float32 steps (6e-8 each) of variation.
  const Volume tiny = field({40, 36, 34}, DType::f32, 1e-7, 1.0);
  const std::string message = compress_error(tiny, fixed_rank(), dir);
  EXPECT_TRUE(contains(message, "sample.nrrd: samples: the values span only")) << message;
  EXPECT_TRUE(contains(message, "--psnr")) << message;
  // The target mode codes each brick about its mean: PSNR 40 over the data's own range.
  compress(tiny, dir.path() / "tiny.strata", psnr(40));
  const TaVolume t(dir.path() / "tiny.strata");
  const ErrorMetrics e = compare_volumes(as_f32(tiny), t.decode_box(0, Box::whole(tiny.dims()), t.rank()));
  const auto [lo, hi] = value_range(tiny);
  EXPECT_LE(e.rmse, (hi - lo) * 1e-2);
  // A range of 1/100 of the magnitude is inside what the fixed-rank mode takes.
  EXPECT_EQ(compress_error(field({40, 36, 34}, DType::f32, 5e-3, 1.0), fixed_rank(), dir), "");
}

TEST(TaCodableRange, ThinVolumesCostNoMoreThanTheirBricksStoredLosslessly) {
  const test::TempDir dir;
  // 33 x 1 x 70 of 16-bit noise. Level 0's bricks (core 28, overlap 2) store x in [0, 30) and
  // [26, 33), z in [0, 30), [26, 58), [54, 70): 37/33 x 78/70 = 1.25 samples per voxel at 16
  // bits; levels 1 and 2 (17 x 1 x 35, 9 x 1 x 18) store 17 x 39 + 9 x 18 = 825 means, whose
  // eighths span more than 16 bits, at 32 bits; the index and metadata of 9 bricks take at
  // most 3.5 bits per voxel (measured 2.3 and 3.5). (2310 x 1.25 x 16 + 825 x 32) / 2310 + 3.5
  // = 34.9 bits per voxel (it was 55 for the fixed-rank mode, 43 at --psnr 40).
  const Volume thin = uniform_integers({33, 1, 70}, DType::u16, 65535, 1);
  // 160 x 160 x 1 of 8-bit noise. Boxes per axis: level 0 180/160 (at 8 bits), level 1 88/80,
  // level 2 44/40 (16-bit codes of quarters and sixteenths), levels 3-5 at most 32 bits for
  // 525 samples: 8 x 1.266 + 16 x (1.21 / 4 + 1.21 / 16) + 32 x 525 / 25600 + 0.2 (index) = 16.9
  // bits per voxel.
  const Volume flat = uniform_integers({160, 160, 1}, DType::u8, 255, 2);
  for (const CompressParams& p : {fixed_rank(), psnr(40)}) {
    const CompressReport t = compress(thin, dir.path() / "thin.strata", p);
    EXPECT_LE(bits_per_voxel(t), 34.9);
    const CompressReport f = compress(flat, dir.path() / "flat.strata", p);
    EXPECT_LE(bits_per_voxel(f), 16.9);
  }
  // At rank 16 every brick of the image costs more than its 32 x 32 samples: all are stored
  // losslessly, so the image decodes exactly.
  compress(flat, dir.path() / "flat.strata", fixed_rank());
  const TaVolume decoded(dir.path() / "flat.strata");
  EXPECT_EQ(max_abs_diff(as_f32(flat), decoded.decode_box(0, Box::whole(flat.dims()), decoded.rank())).value, 0.0);
}
