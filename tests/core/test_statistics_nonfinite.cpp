// Statistics of float volumes holding NaN and infinities (found by fuzz/fuzz_raw_sidecar: the
// histogram bin of such a sample was a float-to-integer cast of NaN, undefined behaviour).
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

TEST(CoreStatisticsNonFinite, NanAndInfinitiesAreBinnedAtTheEnds) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  const float values[] = {kNan, 0.0f, 1.0f, kInf, -kInf, 2.0f, kNan, 3.0f};
  Volume v({8, 1, 1}, DType::f32);
  for (int x = 0; x < 8; ++x) v.samples<float>()[std::size_t(x)] = values[x];
  const VolumeStatistics st = compute_statistics(v);
  EXPECT_EQ(st.voxel_count, 8u);
  EXPECT_EQ(histogram_total(st), 8u);
}

TEST(CoreStatisticsNonFinite, AllNanVolume) {
  Volume v({4, 2, 1}, DType::f64);
  for (auto& x : v.samples<double>()) x = std::numeric_limits<double>::quiet_NaN();
  const VolumeStatistics st = compute_statistics(v);
  EXPECT_EQ(st.voxel_count, 8u);
  EXPECT_EQ(st.histogram[0], 8u);
}

TEST(CoreStatisticsNonFinite, FiniteValuesKeepTheirBins) {
  Volume v({16, 1, 1}, DType::f32);
  for (int x = 0; x < 16; ++x) v.samples<float>()[std::size_t(x)] = float(x);
  const VolumeStatistics st = compute_statistics(v);
  for (std::size_t b = 0; b < st.histogram.size(); ++b) EXPECT_EQ(st.histogram[b], 1u) << "bin " << b;
}

}  // namespace
}  // namespace strata
