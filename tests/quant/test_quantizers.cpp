#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "strata/core/error.hpp"
#include "strata/quant/quantizers.hpp"

namespace strata::quant {
namespace {

constexpr double kEps = std::numeric_limits<float>::epsilon();  // 2^-23

// Values with magnitudes spread log-uniformly over [xmax * 1e-6, xmax], both signs, plus the
// extremes, the way core coefficients spread.
std::vector<float> signed_log_spread(float xmax, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> exponent(-6.0, 0.0);
  std::vector<float> v{0.0f, -0.0f, xmax, -xmax};
  for (int i = 0; i < 4000; ++i) {
    const double magnitude = double(xmax) * std::pow(10.0, exponent(rng));
    v.push_back(float(i % 2 ? magnitude : -magnitude));
  }
  return v;
}

// The decoders evaluate 2^(m h) in float: m h is rounded (relative 2^-24, i.e. an exponent
// error of 2^-24 L for L = log2 of the largest decoded magnitude), exp2_approx adds ~2 ulp and
// the "- 1" one more; so the decoded magnitude is off by at most (1 + |x|)(ln2 2^-24 L + 4 eps).
double float_slack(double x, double log_range) { return (1.0 + std::abs(x)) * (0.7 * 0x1p-24 * log_range + 4 * kEps); }

TEST(QuantExp2Approx, MatchesExp2ToAFewUlps) {
  for (double x = -30.0; x < 127.0; x += 0.0137) {
    const double expected = std::exp2(double(float(x)));
    EXPECT_NEAR(exp2_approx(float(x)), expected, 2 * kEps * expected) << x;
  }
  EXPECT_EQ(exp2_approx(0.0f), 1.0f);
}

TEST(QuantLinearQuantizer, ErrorIsWithinHalfAStep) {
  for (int bits : {8, 12, 16}) {
    const float lo = -0.73f, hi = 0.91f;
    const LinearQuantizer q(lo, hi, bits);
    EXPECT_NEAR(q.step(), (hi - lo) / ((1 << bits) - 1), 1e-7);
    std::mt19937 rng{unsigned(bits)};
    std::uniform_real_distribution<float> dist(lo, hi);
    // Decoding lo + code * step in float adds a few ulps of max(|lo|, |hi|).
    const double slack = 4 * kEps * 0.91;
    for (int i = 0; i < 5000; ++i) {
      const float x = dist(rng);
      EXPECT_LE(std::abs(q.decode(q.encode(x)) - x), q.max_error() + slack) << x;
    }
    EXPECT_EQ(q.encode(lo), 0u);
    EXPECT_EQ(q.encode(hi), q.levels());
    EXPECT_NEAR(q.decode(q.levels()), hi, slack);
  }
}

TEST(QuantLinearQuantizer, ClampsOutOfRangeAndHandlesEmptyRange) {
  const LinearQuantizer q(0.0f, 1.0f, 8);
  EXPECT_EQ(q.encode(-5.0f), 0u);
  EXPECT_EQ(q.encode(7.0f), 255u);
  const LinearQuantizer flat(0.25f, 0.25f, 8);
  EXPECT_EQ(flat.encode(0.25f), 0u);
  EXPECT_EQ(flat.decode(0), 0.25f);
  EXPECT_THROW(LinearQuantizer(1.0f, 0.0f, 8), Error);
  EXPECT_THROW(LinearQuantizer(0.0f, 1.0f, 0), Error);
}

// Eq. 2 is uniform in log2(1 + |x|): the error at x is bounded by the log step around x.
TEST(QuantLogQuantizer, ErrorIsWithinTheLogStepBound) {
  for (float xmax : {50000.0f, 1000.0f, 0.5f}) {
    for (int bits : {8, 12, 16}) {
      const LogQuantizer q(xmax, bits);
      const double log_range = std::log2(1.0 + xmax);
      EXPECT_NEAR(q.log_step(), log_range / ((1 << (bits - 1)) - 1), 1e-6 * log_range);
      for (float x : signed_log_spread(xmax, unsigned(bits))) {
        const float y = q.decode(q.encode(x));
        EXPECT_LE(std::abs(double(y) - x), q.error_bound(x) + float_slack(x, log_range))
            << "xmax " << xmax << " bits " << bits << " x " << x;
      }
    }
  }
}

TEST(QuantLogQuantizer, EightBitsAreSignPlusSevenMagnitudeBits) {
  const LogQuantizer q(1000.0f, 8);
  EXPECT_EQ(q.encode(1000.0f), 127u);
  EXPECT_EQ(q.encode(-1000.0f), 255u);
  EXPECT_NEAR(q.decode(127), 1000.0f, float_slack(1000, std::log2(1001.0)));
  EXPECT_NEAR(q.decode(255), -1000.0f, float_slack(1000, std::log2(1001.0)));
}

TEST(QuantLogQuantizer, PreservesSignAndZero) {
  const LogQuantizer q(100.0f, 8);
  EXPECT_EQ(q.encode(0.0f), 0u);
  EXPECT_EQ(q.encode(-0.0f), 0u);  // one code for zero
  EXPECT_EQ(q.decode(0), 0.0f);
  EXPECT_FALSE(std::signbit(q.decode(0)));
  for (float x : signed_log_spread(100.0f, 3)) {
    const float y = q.decode(q.encode(x));
    EXPECT_GE(double(x) * double(y), 0.0) << x;  // never flips the sign
    if (std::abs(x) > 1.0f) {
      EXPECT_EQ(std::signbit(x), std::signbit(y));
    }
  }
}

TEST(QuantLogQuantizer, CodesAreMonotoneInMagnitude) {
  const LogQuantizer q(500.0f, 12);
  std::uint32_t previous = 0;
  for (float x = 0.0f; x <= 500.0f; x += 0.37f) {
    const std::uint32_t code = q.encode(x);
    EXPECT_GE(code, previous);
    previous = code;
  }
}

TEST(QuantLogQuantizer, ZeroRangeEncodesEverythingAsZero) {
  const LogQuantizer q(0.0f, 8);
  EXPECT_EQ(q.encode(0.0f), 0u);
  EXPECT_EQ(q.decode(q.encode(0.0f)), 0.0f);
  EXPECT_THROW(LogQuantizer(std::numeric_limits<float>::infinity(), 8), Error);
  EXPECT_THROW(LogQuantizer(-1.0f, 8), Error);
}

TEST(QuantMuLawQuantizer, ErrorIsWithinTheLogStepBound) {
  for (float mu : {1.0f, 255.0f, 1e5f}) {
    for (int bits : {8, 12, 16}) {
      const float xmax = 3.0f;
      const MuLawQuantizer q(xmax, mu, bits);
      const double log_range = std::log2(1.0 + mu);
      for (float x : signed_log_spread(xmax, unsigned(bits) + 7)) {
        const float y = q.decode(q.encode(x));
        // The slack scales with xmax / mu + |x|, the factor in front of 2^(m h) - 1.
        const double slack = (double(q.scale()) + std::abs(x)) * (0.7 * 0x1p-24 * log_range + 6 * kEps);
        EXPECT_LE(std::abs(double(y) - x), q.error_bound(x) + slack) << "mu " << mu << " bits " << bits << " x " << x;
        EXPECT_GE(double(x) * double(y), 0.0);
      }
      EXPECT_EQ(q.encode(0.0f), 0u);
      EXPECT_EQ(q.decode(0), 0.0f);
      EXPECT_EQ(q.encode(xmax), (1u << (bits - 1)) - 1);
    }
  }
}

// mu-law depends only on |x| / xmax: rescaling data and range by a power of two changes no code.
TEST(QuantMuLawQuantizer, IsScaleInvariant) {
  const MuLawQuantizer a(2.0f, 255.0f, 8), b(2.0f * 4096.0f, 255.0f, 8);
  for (float x : signed_log_spread(2.0f, 11)) EXPECT_EQ(a.encode(x), b.encode(x * 4096.0f)) << x;
}

// Eq. 2 literally is not: the same relative data quantizes differently at different scales.
TEST(QuantLogQuantizer, IsNotScaleInvariant) {
  const LogQuantizer small(1.0f, 8), large(65536.0f, 8);
  EXPECT_NE(small.encode(0.01f), large.encode(0.01f * 65536.0f));
}

}  // namespace
}  // namespace strata::quant
