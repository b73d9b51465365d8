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

TEST_P(TaBrickStatsPerIsa, AnEmptyRangePutsEveryValueInBinZero) {
  const ScopedIsaLimit limit(isa());
  const std::vector<float> a = test_values(40, 3, false);
  EXPECT_EQ(brick_stats(a, a, HistogramRange{5.0, 5.0}).bits, 1u);
}

STRATA_INSTANTIATE_PER_ISA(TaBrickStatsPerIsa, Isa::generic, Isa::avx2, Isa::avx512);

}  // namespace strata::ta
