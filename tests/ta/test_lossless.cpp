// The lossless configuration (f32 coefficients, rank == brick width) turns the codec into an
// exact change of basis: whatever differs from the input then comes from gathering the wrong
// samples, clamping wrongly at the borders, misplacing cores or building parents wrongly.
#include <gtest/gtest.h>

#include "ta/ta_test_util.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;

namespace {

// 45x37x29 is a multiple of the core (12) on no axis: every level has partial bricks at the far
// edges and clamped samples on all six sides. Three levels: 45x37x29, 23x19x15, 12x10x8.
class TaLossless : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    input_ = new Volume(prisms({45, 37, 29}, 11));
    input_->set_spacing({0.5, 1.0, 2.0});
    report_ = new CompressReport(compress(*input_, path(), params(16, 2, 16, "f32", 0)));
    volume_ = new TaVolume(path());
    const auto [lo, hi] = value_range(*input_);
    range_ = hi - lo;
  }
  static void TearDownTestSuite() {
    delete volume_;
    delete report_;
    delete input_;
    delete dir_;
  }
  static std::filesystem::path path() { return *dir_ / "lossless.strata"; }
  // Full-rank float Tucker is exact up to rounding: a few ulps of the brick's magnitude, well
  // under 1e-5 of the value range for these data; any misplaced voxel is off by ~the range.
  static double tolerance() { return 1e-5 * range_; }

  static inline test::TempDir* dir_ = nullptr;
  static inline Volume* input_ = nullptr;
  static inline CompressReport* report_ = nullptr;
  static inline TaVolume* volume_ = nullptr;
  static inline double range_ = 0;
};

}  // namespace

TEST_F(TaLossless, MetadataDescribesTheSourceAndTheCodec) {
  EXPECT_EQ(volume_->source_info().dims, (Extent{45, 37, 29}));
  EXPECT_EQ(volume_->source_info().dtype, DType::u16);
  EXPECT_EQ(volume_->source_info().spacing, (Spacing{0.5, 1.0, 2.0}));
  EXPECT_EQ(volume_->rank(), 16);
  EXPECT_EQ(volume_->quant_name(), "f32");
  EXPECT_EQ(volume_->geometry().level_count(), 3);
  EXPECT_EQ(volume_->geometry().level(1).dims, (Extent{23, 19, 15}));
  EXPECT_EQ(volume_->geometry().level(2).dims, (Extent{12, 10, 8}));
  const auto [lo, hi] = value_range(*input_);
  EXPECT_EQ(volume_->value_min(), lo);
  EXPECT_EQ(volume_->value_max(), hi);
  EXPECT_GT(range_, 1000.0);  // the data are not trivially flat
  // Report and index agree on the brick counts: 4x4x3 + 2x2x2 + 1.
  ASSERT_EQ(report_->levels.size(), 3u);
  EXPECT_EQ(report_->levels[0].bricks, 48);
  EXPECT_EQ(report_->levels[1].bricks, 8);
  EXPECT_EQ(report_->levels[2].bricks, 1);
  EXPECT_EQ(volume_->container().bricks().size(), 57u);
  EXPECT_EQ(report_->file_bytes, std::filesystem::file_size(path()));
  EXPECT_EQ(report_->input_voxels, 45u * 37u * 29u);
}

TEST_F(TaLossless, Level0EqualsTheInput) {
  const Volume decoded = volume_->decode_box(0, Box::whole({45, 37, 29}), 16);
  EXPECT_EQ(decoded.dtype(), DType::f32);
  EXPECT_EQ(decoded.dims(), (Extent{45, 37, 29}));
  EXPECT_EQ(decoded.spacing(), (Spacing{0.5, 1.0, 2.0}));
  const MaxDiff d = max_abs_diff(*input_, decoded);
  EXPECT_LE(d.value, tolerance()) << "at " << d.at.to_string() << " (range " << range_ << ")";
}

TEST_F(TaLossless, EveryStoredBrickHoldsItsClampedSampleBox) {
  // The overlap region is stored too (the renderer interpolates across it): each brick's B^3
  // samples must be the input at its sample box with indices clamped to the volume.
  const OctreeGeometry& g = volume_->geometry();
  tensor::BrickReconstructor reconstructor;
  DecodeScratch scratch;
  std::vector<float> brick(16 * 16 * 16);
  const Extent d = input_->dims();
  double worst = 0;
  for (std::int32_t bz = 0; bz < 3; ++bz)
    for (std::int32_t by = 0; by < 4; ++by)
      for (std::int32_t bx = 0; bx < 4; ++bx) {
        volume_->decode_brick({0, bx, by, bz}, 16, brick, reconstructor, scratch);
        const Box s = g.brick_sample_box(0, bx, by, bz);
        for (int k = 0; k < 16; ++k)
          for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i) {
              const double expected = input_->value(std::clamp<std::int64_t>(s.lo.x + i, 0, d.x - 1),
                                                    std::clamp<std::int64_t>(s.lo.y + j, 0, d.y - 1),
                                                    std::clamp<std::int64_t>(s.lo.z + k, 0, d.z - 1));
              worst = std::max(worst, std::abs(expected - brick[std::size_t((k * 16 + j) * 16 + i)]));
            }
      }
  EXPECT_LE(worst, tolerance());
}

TEST_F(TaLossless, Level1IsThe2x2x2AverageOfDecodedLevel0) {
  const Volume level0 = volume_->decode_box(0, Box::whole({45, 37, 29}), 16);
  const Volume level1 = volume_->decode_box(1, Box::whole({23, 19, 15}), 16);
  EXPECT_EQ(level1.spacing(), (Spacing{1.0, 2.0, 4.0}));  // source spacing * 2^level
  const Volume expected = average_2x2x2(level0);
  const MaxDiff d = max_abs_diff(expected, level1);
  EXPECT_LE(d.value, tolerance()) << "at " << d.at.to_string();
  // The odd last x/y/z samples average with themselves: check one corner explicitly against
  // the input (x=44, y=36 and z=28 have no partner).
  EXPECT_NEAR(level1.value(22, 18, 14), input_->value(44, 36, 28), 2 * tolerance());
  EXPECT_NEAR(level1.value(22, 0, 0),
              (input_->value(44, 0, 0) + input_->value(44, 1, 0) + input_->value(44, 0, 1) + input_->value(44, 1, 1)) / 4,
              2 * tolerance());
}

TEST_F(TaLossless, Level2IsThe2x2x2AverageOfDecodedLevel1) {
  const Volume level1 = volume_->decode_box(1, Box::whole({23, 19, 15}), 16);
  const Volume level2 = volume_->decode_box(2, Box::whole({12, 10, 8}), 16);
  const MaxDiff d = max_abs_diff(average_2x2x2(level1), level2);
  EXPECT_LE(d.value, tolerance()) << "at " << d.at.to_string();
  // And, transitively, the 4x4x4 average of the input (clamped at the odd edges twice).
  const MaxDiff d2 = max_abs_diff(average_2x2x2(average_2x2x2(as_f32(*input_))), level2);
  EXPECT_LE(d2.value, 3 * tolerance()) << "at " << d2.at.to_string();
}

TEST_F(TaLossless, NoOverlapAndSingleVoxelSlicesAlsoRoundTrip) {
  // overlap 0 (core == brick) and a 1-voxel-thick volume: clamping replicates one slice.
  test::TempDir dir;
  const Volume v = prisms({20, 9, 1}, 3);
  compress(v, dir / "flat.strata", params(8, 0, 8, "f32", 0));
  TaVolume t(dir / "flat.strata");
  EXPECT_EQ(t.geometry().level_count(), 3);  // 20x9x1 -> 10x5x1 -> 5x3x1
  const MaxDiff d = max_abs_diff(v, t.decode_box(0, Box::whole({20, 9, 1}), 8));
  const auto [lo, hi] = value_range(v);
  EXPECT_LE(d.value, 1e-5 * (hi - lo)) << "at " << d.at.to_string();
  const MaxDiff d1 = max_abs_diff(average_2x2x2(as_f32(v)), t.decode_box(1, Box::whole({10, 5, 1}), 8));
  EXPECT_LE(d1.value, 1e-5 * (hi - lo)) << "at " << d1.at.to_string();
}

TEST_F(TaLossless, OverlapWiderThanTheCoreStillGathersTheRightSamples) {
  // brick 8, overlap 3: cores of 2 voxels, so a brick row needs slices several rows ahead and
  // behind (the streaming window must hold them). 9x7x11 -> 5x4x6 -> 3x2x3 -> 2x1x2.
  test::TempDir dir;
  const Volume v = prisms({9, 7, 11}, 8);
  const CompressReport r = compress(v, dir / "wide.strata", params(8, 3, 8, "f32", 0));
  TaVolume t(dir / "wide.strata");
  ASSERT_EQ(t.geometry().level_count(), 4);
  EXPECT_EQ(t.container().bricks().size(), 5u * 4 * 6 + 3 * 2 * 3 + 2 * 1 * 2 + 1);
  EXPECT_EQ(r.levels[0].bricks, 120);
  const auto [lo, hi] = value_range(v);
  const double tol = 1e-5 * (hi - lo);
  const Volume l0 = t.decode_box(0, Box::whole({9, 7, 11}), 8);
  const MaxDiff d0 = max_abs_diff(v, l0);
  EXPECT_LE(d0.value, tol) << "at " << d0.at.to_string();
  const Volume l1 = t.decode_box(1, Box::whole({5, 4, 6}), 8);
  const MaxDiff d1 = max_abs_diff(average_2x2x2(l0), l1);
  EXPECT_LE(d1.value, tol) << "at " << d1.at.to_string();
  const MaxDiff d2 = max_abs_diff(average_2x2x2(l1), t.decode_box(2, Box::whole({3, 2, 3}), 8));
  EXPECT_LE(d2.value, tol) << "at " << d2.at.to_string();
}
