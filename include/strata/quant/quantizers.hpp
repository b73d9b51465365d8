#pragma once
/// @file
/// @brief Scalar quantizers of paper 1 §4.1: linear, logarithmic and mu-law.
///
/// Codes are unsigned integers of `bits` bits. The signed (logarithmic, mu-law) quantizers use
/// sign-magnitude codes: bit (bits-1) is the sign, the low bits-1 bits the magnitude, so "8-bit
/// log" has 7 magnitude bits (M = 127 levels above zero), as the paper's byte-aligned Q = 8 with a
/// separate sign bit implies. Zero always encodes to code 0 and decodes to exactly 0.
///
/// Error bounds (what the tests check), for |x| within the quantizer's range:
///   linear : |x̃ - x| <= step / 2,  step = (hi - lo) / (2^bits - 1)
///   log    : codes are uniform in L(x) = log2(1 + |x|) with step h = L(xmax) / M, so
///            |x̃ - x| <= (1 + |x|)(2^(h/2) - 1)
///   mu-law : uniform in L(x) = log2(1 + mu |x| / xmax), h = log2(1 + mu) / M, so
///            |x̃ - x| <= (xmax / mu + |x|)(2^(h/2) - 1)
/// plus float rounding of the decoded value (a few ulps).
#include <cstdint>

namespace strata::quant {

/// @brief 2^x for x in [-126, 128) to ~1 ulp, branch-free so loops over it vectorise. Shared by the
/// scalar and the bulk decoders; the bulk decoder's FMA builds round the Horner steps once
/// instead of twice, so values agree to a few ulps (identical within one build).
inline float exp2_approx(float x) {
  // x = n + f with n integer, f in [-0.5, 0.5]: 2^x = 2^n 2^f. Adding and subtracting 1.5 * 2^23
  // rounds to nearest in float arithmetic without a rounding instruction (SSE2 has none).
  constexpr float kRound = 12582912.0f;
  const float n = (x + kRound) - kRound;
  const float f = x - n;
  // Taylor series of e^(f ln 2) to degree 7: remainder < (0.347)^8 / 8! = 5e-9 on |f| <= 0.5.
  float p = 1.5252733804059841e-05f;
  p = p * f + 1.5403530393381610e-04f;
  p = p * f + 1.3333558146428443e-03f;
  p = p * f + 9.6181291076284772e-03f;
  p = p * f + 5.5504108664821580e-02f;
  p = p * f + 2.4022650695910071e-01f;
  p = p * f + 6.9314718055994531e-01f;
  p = p * f + 1.0f;
  // Scale by 2^n through the exponent field; n + 127 is in [1, 254] for x in [-126, 127.5).
  const std::uint32_t bits = std::uint32_t(std::int32_t(n) + 127) << 23;
  return p * __builtin_bit_cast(float, bits);
}

/// @brief Eq. 1: code = round((2^bits - 1)(x - lo) / (hi - lo)). Values outside [lo, hi] are clamped.
class LinearQuantizer {
 public:
  LinearQuantizer(float lo, float hi, int bits);  // bits in 1..24; lo <= hi, both finite

  std::uint32_t encode(float x) const;
  // Codes are < 2^24, so the signed conversion is exact (and vectorises without AVX-512).
  float decode(std::uint32_t code) const { return lo_ + float(std::int32_t(code)) * step_; }
  float step() const { return step_; }
  double max_error() const { return 0.5 * double(step_); }
  std::uint32_t levels() const { return levels_; }  // 2^bits - 1

 private:
  float lo_, step_;
  double inverse_step_;
  std::uint32_t levels_;
};

/// @brief Eq. 2 with a separate sign bit.
class LogQuantizer {
 public:
  LogQuantizer(float max_abs, int bits);  // bits in 2..24 (sign + magnitude); max_abs finite, >= 0

  std::uint32_t encode(float x) const;
  // Inline so the bulk decoder's loops vectorise: |x̃| = 2^(m h) - 1.
  float decode(std::uint32_t code) const {
    const float magnitude = exp2_approx(float(std::int32_t(code & magnitude_levels_)) * log_step_) - 1.0f;
    return (code >> magnitude_bits_) & 1u ? -magnitude : magnitude;
  }
  double error_bound(double x) const;
  float log_step() const { return log_step_; }  // h

 private:
  float log_step_;          // h = log2(1 + max_abs) / M
  double inverse_log_step_;
  std::uint32_t magnitude_levels_;  // M
  int magnitude_bits_;
};

/// @brief Scale-invariant logarithmic curve: Eq. 2 applied to mu |x| / xmax instead of |x|, so the
/// code distribution does not depend on the units of the data.
class MuLawQuantizer {
 public:
  MuLawQuantizer(float max_abs, float mu, int bits);  // mu > 0

  std::uint32_t encode(float x) const;
  float decode(std::uint32_t code) const {  // |x̃| = (xmax / mu)(2^(m h) - 1)
    const float magnitude = scale_ * (exp2_approx(float(std::int32_t(code & magnitude_levels_)) * log_step_) - 1.0f);
    return (code >> magnitude_bits_) & 1u ? -magnitude : magnitude;
  }
  double error_bound(double x) const;
  float log_step() const { return log_step_; }  // h = log2(1 + mu) / M
  float scale() const { return scale_; }        // xmax / mu

 private:
  float log_step_, scale_;
  double inverse_log_step_;
  std::uint32_t magnitude_levels_;
  int magnitude_bits_;
};

}  // namespace strata::quant
