// Statistics of float volumes holding NaN and infinities: counted apart, the rest describes the
// finite values (fuzz/fuzz_raw_sidecar found the histogram bin of such a sample was once a
// float-to-integer cast of NaN, undefined behaviour).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "strata/core/statistics.hpp"

namespace strata {
namespace {

std::uint64_t histogram_total(const VolumeStatistics& st) {
  std::uint64_t total = 0;
  for (auto c : st.histogram) total += c;
  return total;
}

// NaN and infinities are counted apart; range, mean, spread and histogram describe the finite
// values (0, 1, 2, 3: mean 1.5, variance 1.25).
TEST(CoreStatisticsNonFinite, NanAndInfinitiesAreCountedApart) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  const float values[] = {kNan, 0.0f, 1.0f, kInf, -kInf, 2.0f, kNan, 3.0f};
  Volume v({8, 1, 1}, DType::f32);
  for (int x = 0; x < 8; ++x) v.samples<float>()[std::size_t(x)] = values[x];
  const VolumeStatistics st = compute_statistics(v);
  EXPECT_EQ(st.voxel_count, 8u);
  EXPECT_EQ(st.nan_count, 2u);
  EXPECT_EQ(st.positive_infinity_count, 1u);
  EXPECT_EQ(st.negative_infinity_count, 1u);
  EXPECT_EQ(st.finite_count(), 4u);
  EXPECT_EQ(st.min, 0.0);
  EXPECT_EQ(st.max, 3.0);
  EXPECT_DOUBLE_EQ(st.mean, 1.5);
  EXPECT_DOUBLE_EQ(st.stddev, std::sqrt(1.25));
  EXPECT_EQ(histogram_total(st), 4u);
  EXPECT_EQ(st.histogram[0], 1u);   // 0
  EXPECT_EQ(st.histogram[15], 1u);  // 3
  EXPECT_DOUBLE_EQ(st.zero_fraction, 1.0 / 8.0);
}

// Slabs whose only values are NaN do not disturb the range of the others, in either order.
TEST(CoreStatisticsNonFinite, NanOnlySlabsLeaveTheRangeAlone) {
  Volume nan_slab({3, 1, 1}, DType::f64), values({2, 1, 1}, DType::f64);
  for (auto& x : nan_slab.samples<double>()) x = std::numeric_limits<double>::quiet_NaN();
  values.samples<double>()[0] = -4;
  values.samples<double>()[1] = 6;
  for (const bool nan_first : {true, false}) {
    StatisticsAccumulator acc;
    acc.add(nan_first ? nan_slab : values);
    acc.add(nan_first ? values : nan_slab);
    const VolumeStatistics st = acc.result();
    EXPECT_EQ(st.min, -4.0);
    EXPECT_EQ(st.max, 6.0);
    EXPECT_EQ(st.mean, 1.0);
    EXPECT_EQ(st.nan_count, 3u);
    EXPECT_EQ(histogram_total(st), 2u);
  }
}

TEST(CoreStatisticsNonFinite, AllNanVolume) {
  Volume v({4, 2, 1}, DType::f64);
  for (auto& x : v.samples<double>()) x = std::numeric_limits<double>::quiet_NaN();
  const VolumeStatistics st = compute_statistics(v);
  EXPECT_EQ(st.voxel_count, 8u);
  EXPECT_EQ(st.nan_count, 8u);
  EXPECT_EQ(st.finite_count(), 0u);
  EXPECT_TRUE(std::isnan(st.min) && std::isnan(st.max) && std::isnan(st.mean));
  EXPECT_EQ(histogram_total(st), 0u);
}

TEST(CoreStatisticsNonFinite, FiniteValuesKeepTheirBins) {
  Volume v({16, 1, 1}, DType::f32);
  for (int x = 0; x < 16; ++x) v.samples<float>()[std::size_t(x)] = float(x);
  const VolumeStatistics st = compute_statistics(v);
  for (std::size_t b = 0; b < st.histogram.size(); ++b) EXPECT_EQ(st.histogram[b], 1u) << "bin " << b;
}

}  // namespace
}  // namespace strata
