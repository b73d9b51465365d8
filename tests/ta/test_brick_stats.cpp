// Culling statistics of a brick (src/ta/brick_stats.cpp) at every instruction-set level they
// are compiled for, against a scalar reference written from the format's bin rule.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "strata/store/brick_histogram.hpp"
#include "support/isa_test.hpp"
#include "ta/brick_stats.hpp"

namespace strata::ta {
namespace {

// Values inside and outside [lo, hi], bin edges, negative zero and (optionally) a NaN.
std::vector<float> test_values(std::size_t n, unsigned seed, bool with_nan) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> wide(-150.0f, 1250.0f);
  std::vector<float> v(n);
  for (float& x : v) x = wide(rng);
  if (n > 3) {
    v[1] = 100.0f + 1000.0f * 17.0f / 64.0f;  // exactly on the edge of bin 17
    v[2] = -0.0f;
    v[n - 1] = 1100.0f;  // hi itself: the last bin
  }
  if (with_nan && n > 5) v[n / 2] = std::numeric_limits<float>::quiet_NaN();
  return v;
}

BrickStats reference_stats(const std::vector<float>& a, const std::vector<float>& b, const HistogramRange& r) {
  const store::HistogramBinning bins(r.lo, r.hi);
  BrickStats st{a[0], a[0], 0};
  for (const auto* v : {&a, &b})
    for (float x : *v) {
      st.lo = std::min(st.lo, x);
      st.hi = std::max(st.hi, x);
      st.bits |= std::uint64_t(1) << bins.bin(double(x));
    }
  return st;
}

}  // namespace

class TaBrickStatsPerIsa : public test::IsaTest {};

TEST_P(TaBrickStatsPerIsa, EqualTheScalarReference) {
  const ScopedIsaLimit limit(isa());
  const HistogramRange range{100.0, 1100.0};
  // Lengths around every vector width and unroll (4, 8, 16, 32 floats) and a whole brick.
  for (const std::size_t n : {1u, 3u, 15u, 16u, 17u, 31u, 33u, 100u, 32768u})
    for (const bool with_nan : {false, true}) {
      SCOPED_TRACE(std::to_string(n) + (with_nan ? " with NaN" : ""));
      const std::vector<float> a = test_values(n, unsigned(n), with_nan), b = test_values(n + 5, unsigned(n) + 1, false);
      const BrickStats got = brick_stats(a, b, range), want = reference_stats(a, b, range);
      EXPECT_EQ(got.bits, want.bits);
      EXPECT_EQ(got.lo, want.lo);
      EXPECT_EQ(got.hi, want.hi);
    }
}

TEST_P(TaBrickStatsPerIsa, NanSamplesAreIgnoredWhereverTheyStand) {
  // A NaN in the same vector lane as the minimum (or maximum), after it, before it, or as the
  // very first sample must not hide the other values of that lane; NaN goes to bin 0 only.
  const ScopedIsaLimit limit(isa());
  const HistogramRange range{0.0, 64.0};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const std::size_t at_nan : {0u, 3u, 19u, 35u, 63u})
    for (const std::size_t at_extreme : {0u, 3u, 19u, 51u}) {
      if (at_nan == at_extreme) continue;
      std::vector<float> v(64, 5.5f);
      v[at_extreme] = -100.0f;
      v[(at_extreme + 16) % 64] = 1000.0f;
      v[at_nan] = nan;
      if ((at_extreme + 16) % 64 == at_nan) continue;
      SCOPED_TRACE("NaN at " + std::to_string(at_nan) + ", minimum at " + std::to_string(at_extreme));
      const BrickStats st = brick_stats(v, std::span<const float>(v).first(1), range);
      EXPECT_EQ(st.lo, -100.0f);
      EXPECT_EQ(st.hi, 1000.0f);
      EXPECT_EQ(st.bits, (std::uint64_t(1) << 0) | (std::uint64_t(1) << 5) | (std::uint64_t(1) << 63));
    }
  const std::vector<float> only_nan(20, nan);
  const BrickStats st = brick_stats(only_nan, only_nan, range);
  EXPECT_TRUE(std::isnan(st.lo) && std::isnan(st.hi));
  EXPECT_EQ(st.bits, 1u);
}

TEST_P(TaBrickStatsPerIsa, AnEmptyRangePutsEveryValueInBinZero) {
  const ScopedIsaLimit limit(isa());
  const std::vector<float> a = test_values(40, 3, false);
  EXPECT_EQ(brick_stats(a, a, HistogramRange{5.0, 5.0}).bits, 1u);
}

STRATA_INSTANTIATE_PER_ISA(TaBrickStatsPerIsa, Isa::generic, Isa::avx2, Isa::avx512);

}  // namespace strata::ta
