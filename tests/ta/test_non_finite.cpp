// NaN and infinite samples (ta/non_finite.hpp): every mode of the compressor keeps them exactly
// where they were, holds its target on the other voxels, stores all-NaN bricks as constants and
// averages only the finite voxels into the coarser levels; the masked payload refuses damage.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "strata/core/metrics.hpp"
#include "strata/core/threads.hpp"
#include "strata/store/zstd_frame.hpp"
#include "ta/non_finite.hpp"
#include "ta/ta_test_util.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// 40 x 30 x 26 (bricks of 16, overlap 2: clipped last bricks): a smooth field with noise, NaN
// outside a cylinder (a field of view) and in the last 12 slices (whole bricks), one +inf and
// one -inf inside.
Volume masked_field() {
  Volume v(Extent{40, 30, 26}, DType::f32);
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  float* s = v.samples<float>().data();
  for (std::int64_t z = 0; z < 26; ++z)
    for (std::int64_t y = 0; y < 30; ++y)
      for (std::int64_t x = 0; x < 40; ++x) {
        const bool outside = (x - 20) * (x - 20) + (y - 15) * (y - 15) > 13 * 13 || z >= 14;
        *s++ = outside ? kNaN : 50.0f * std::sin(float(x) / 6) * std::cos(float(y) / 7) + float(z) + noise(rng);
      }
  v.samples<float>()[std::size_t(20 + 40 * (15 + 30 * 5))] = kInf;
  v.samples<float>()[std::size_t(18 + 40 * (12 + 30 * 9))] = -kInf;
  return v;
}

CompressParams mode_params(TargetKind kind, double value) {
  CompressParams p;
  p.layout = {16, 2};
  p.codec.rank = 16;
  p.codec.target = {kind, value};
  return p;
}

// Every non-finite voxel of `original` decodes to the same class in `decoded`, every finite one
// to a finite value; returns the largest error over the finite voxels.
double check_mask_and_max_error(const Volume& original, const Volume& decoded) {
  const auto a = original.samples<float>(), b = decoded.samples<float>();
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i])) {
      EXPECT_TRUE(std::isnan(b[i])) << "voxel " << i;
    } else if (std::isinf(a[i])) {
      EXPECT_EQ(a[i], b[i]) << "voxel " << i;
    } else {
      EXPECT_TRUE(std::isfinite(b[i])) << "voxel " << i;
      worst = std::max(worst, std::abs(double(a[i]) - double(b[i])));
    }
  }
  return worst;
}

// Whether `f` throws a FormatError of context "test" naming `field`.
bool names_field(const std::function<void()>& f, const std::string& field) {
  return test::error_of(f).rfind("test: " + field + ": ", 0) == 0;
}

}  // namespace

TEST(TaNonFinite, EveryModeKeepsTheMaskExactlyAndItsTargetOnTheOtherVoxels) {
  test::TempDir dir;
  const Volume v = masked_field();
  {
    compress(v, dir / "max.strata", mode_params(TargetKind::max_error, 0.5));
    const TaVolume t(dir / "max.strata");
    EXPECT_LE(check_mask_and_max_error(v, t.decode_box(0, Box::whole(v.dims()), t.rank())), 0.5);
  }
  {
    // 40 dB over the finite voxels' range: RMSE at most range / 100 over those voxels.
    compress(v, dir / "psnr.strata", mode_params(TargetKind::psnr, 40));
    const TaVolume t(dir / "psnr.strata");
    const Volume d = t.decode_box(0, Box::whole(v.dims()), t.rank());
    check_mask_and_max_error(v, d);
    const ErrorMetrics e = compare_volumes(v, d);
    EXPECT_EQ(e.masked_mismatched, 0u);
    EXPECT_GT(e.masked_matched, 0u);
    EXPECT_GE(e.psnr_db, 40.0);
  }
  {
    CompressParams fixed;
    fixed.layout = {16, 2};
    fixed.codec.rank = 8;
    compress(v, dir / "rank.strata", fixed);
    const TaVolume t(dir / "rank.strata");
    check_mask_and_max_error(v, t.decode_box(0, Box::whole(v.dims()), t.rank()));
    // The rank slider: a lower rank still restores every mask.
    check_mask_and_max_error(v, t.decode_box(0, Box::whole(v.dims()), 2));
  }
}

TEST(TaNonFinite, AllNaNBricksAreConstantAndCoarseVoxelsAverageTheFiniteOnes) {
  test::TempDir dir;
  const Volume v = masked_field();
  compress(v, dir / "v.strata", mode_params(TargetKind::max_error, 0.5));
  const TaVolume t(dir / "v.strata");
  std::size_t constant_nan = 0, masked = 0;
  for (const store::BrickEntry& e : t.container().bricks()) {
    constant_nan += e.kind == store::PayloadKind::constant && std::isnan(e.min);
    masked += e.kind == store::PayloadKind::masked;
    if (e.kind == store::PayloadKind::masked) {
      EXPECT_TRUE(std::isfinite(e.min) && std::isfinite(e.max) && e.min <= e.max) << store::brick_name(e.key);
    }
  }
  EXPECT_GT(constant_nan, 0u);  // slices 14..25 hold whole bricks of NaN
  EXPECT_GT(masked, 0u);
  // Level 1 voxel (x, y, z) averages level 0's (2x..2x+1, ...): NaN only where all eight are
  // NaN, and within the bound of the finite ones' mean otherwise (each decoded within 0.5).
  const Volume coarse = t.decode_box(1, Box::whole(t.geometry().level(1).dims), t.rank());
  const Extent cd = coarse.dims();
  const auto fine = v.samples<float>();
  for (std::int64_t z = 0; z < cd.z; ++z)
    for (std::int64_t y = 0; y < cd.y; ++y)
      for (std::int64_t x = 0; x < cd.x; ++x) {
        double sum = 0;
        int finite = 0;
        for (int dz = 0; dz < 2; ++dz)
          for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
              const std::int64_t fx = std::min(2 * x + dx, v.dims().x - 1), fy = std::min(2 * y + dy, v.dims().y - 1),
                                 fz = std::min(2 * z + dz, v.dims().z - 1);
              const float s = fine[std::size_t(fx + v.dims().x * (fy + v.dims().y * fz))];
              if (std::isfinite(s)) {
                sum += s;
                ++finite;
              }
            }
        const float c = coarse.samples<float>()[std::size_t(x + cd.x * (y + cd.y * z))];
        if (finite == 0) continue;  // NaN or an infinity: the first child's value
        // Level 1 is coded too (its bound doubles by default): 0.5 for the children plus 1.0.
        ASSERT_TRUE(std::isfinite(c)) << x << "," << y << "," << z;
        EXPECT_NEAR(c, sum / finite, 1.5 + 1e-3) << x << "," << y << "," << z;
      }
}

TEST(TaNonFinite, OutputDoesNotDependOnTheThreadCount) {
  test::TempDir dir;
  const Volume v = masked_field();
  const int threads = thread_count();
  set_thread_count(1);
  compress(v, dir / "one.strata", mode_params(TargetKind::psnr, 45));
  set_thread_count(2);
  compress(v, dir / "two.strata", mode_params(TargetKind::psnr, 45));
  set_thread_count(threads);
  EXPECT_EQ(file_bytes(dir / "one.strata"), file_bytes(dir / "two.strata"));
}

TEST(TaNonFinite, MaskedPayloadsRoundTripAndRefuseDamage) {
  NonFiniteMask mask;
  mask.index = {0, 5, 7};
  mask.value = {kNaN, kInf, -kInf};
  const std::vector<std::byte> inner{std::byte{1}, std::byte{2}, std::byte{3}};
  const std::vector<std::byte> bytes = wrap_masked(mask, 8, store::PayloadKind::raw_packed, 0, inner, 3);
  std::vector<std::byte> scratch;
  const MaskedPayload p = unwrap_masked(bytes, 8, scratch, "test");
  EXPECT_EQ(p.inner, store::PayloadKind::raw_packed);
  EXPECT_EQ(std::vector<std::byte>(p.inner_payload.begin(), p.inner_payload.end()), inner);
  EXPECT_EQ(p.mask.index, mask.index);
  EXPECT_TRUE(std::isnan(p.mask.value[0]));
  EXPECT_EQ(p.mask.value[1], kInf);
  EXPECT_EQ(p.mask.value[2], -kInf);
  // A mask of another brick size, a truncated payload, an unknown inner kind.
  EXPECT_TRUE(names_field([&] { unwrap_masked(bytes, 9, scratch, "test"); }, "masked brick mask"));
  EXPECT_TRUE(names_field([&] { unwrap_masked(std::span(bytes).first(7), 8, scratch, "test"); }, "masked brick mask size"));
  std::vector<std::byte> bad = bytes;
  bad[0] = std::byte{7};
  EXPECT_TRUE(names_field([&] { unwrap_masked(bad, 8, scratch, "test"); }, "masked brick inner kind"));
  // A 7-voxel brick whose packed mask also marks an eighth voxel, and a mask that marks none.
  auto forged = [](std::vector<std::byte> packed_classes) {
    const std::vector<std::byte> frame = store::zstd_compress(packed_classes, 3);
    std::vector<std::byte> out{std::byte{6}, std::byte{0}, std::byte{0}, std::byte{0}, std::byte{0}};
    for (int k = 0; k < 4; ++k) out.push_back(std::byte((frame.size() >> (8 * k)) & 0xFF));
    out.insert(out.end(), frame.begin(), frame.end());
    return out;
  };
  EXPECT_TRUE(names_field([&] { unwrap_masked(forged({std::byte{1}, std::byte{0x40}}), 7, scratch, "test"); },
                          "masked brick mask"));
  EXPECT_TRUE(names_field([&] { unwrap_masked(forged({std::byte{0}, std::byte{0}}), 8, scratch, "test"); },
                          "masked brick mask"));
  EXPECT_EQ(unwrap_masked(forged({std::byte{1}, std::byte{0x10}}), 7, scratch, "test").mask.index,
            (std::vector<std::uint32_t>{0, 6}));
}

// A real SPM-style resampled image (python3-nibabel's test data: NaN outside the field of view):
// compressed to 40 dB, its NaN voxels come back exactly and the PSNR of the others holds.
TEST(TaNonFinite, ARealResampledImageWithNaNOutsideItsFieldOfViewRoundTrips) {
  const std::filesystem::path file = "/usr/lib/python3/dist-packages/nibabel/tests/data/resampled_anat_moved.nii";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "python3-nibabel is not installed";
  test::TempDir dir;
  const Volume original = io::read_volume(file).converted(DType::f32);
  auto source = io::open_volume(file);
  compress_volume(*source, dir / "r.strata", mode_params(TargetKind::psnr, 40), silent_progress());
  const TaVolume t(dir / "r.strata");
  const Volume decoded = t.decode_box(0, Box::whole(original.dims()), t.rank());
  check_mask_and_max_error(original, decoded);
  const ErrorMetrics e = compare_volumes(original, decoded);
  EXPECT_EQ(e.masked_matched, 153u);  // as numpy.isnan counts them
  EXPECT_EQ(e.masked_mismatched, 0u);
  EXPECT_GE(e.psnr_db, 40.0);
}
