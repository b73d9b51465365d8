#include "strata/quant/quantizers.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "strata/core/error.hpp"

namespace strata::quant {
namespace {

void check_bits(int bits, int min_bits, const char* context) {
  // 24 bits: every code is exactly representable as a float, which the decoders rely on.
  if (bits < min_bits || bits > 24) {
    throw Error(std::string(context) + ": bits must be in [" + std::to_string(min_bits) + ", 24], got " +
                std::to_string(bits));
  }
}

// The log decoders compute 2^L with L <= log2(1 + max_abs); exp2_approx needs L < 127.5.
void check_max_abs(float max_abs, const char* context) {
  if (!std::isfinite(max_abs) || max_abs < 0 || max_abs > 1e38f) {
    throw Error(std::string(context) + ": max |x| must be finite, >= 0 and <= 1e38, got " + std::to_string(max_abs));
  }
}

// Rounds t >= 0 to the nearest level and clamps to [0, levels].
std::uint32_t to_level(double t, std::uint32_t levels) {
  return std::uint32_t(std::clamp(std::nearbyint(t), 0.0, double(levels)));
}

std::uint32_t sign_magnitude(float x, std::uint32_t magnitude, int magnitude_bits) {
  const bool negative = std::signbit(x) && magnitude != 0;  // keep a single code for zero
  return (std::uint32_t(negative) << magnitude_bits) | magnitude;
}


}  // namespace

LinearQuantizer::LinearQuantizer(float lo, float hi, int bits) : lo_(lo) {
  check_bits(bits, 1, "LinearQuantizer");
  if (!std::isfinite(lo) || !std::isfinite(hi) || hi < lo) {
    throw Error("LinearQuantizer: range must be finite with lo <= hi, got [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  }
  levels_ = (1u << bits) - 1;
  step_ = float((double(hi) - double(lo)) / levels_);
  inverse_step_ = step_ > 0 ? 1.0 / double(step_) : 0.0;
}

std::uint32_t LinearQuantizer::encode(float x) const {
  return to_level((double(x) - double(lo_)) * inverse_step_, levels_);
}

LogQuantizer::LogQuantizer(float max_abs, int bits) {
  check_bits(bits, 2, "LogQuantizer");
  check_max_abs(max_abs, "LogQuantizer");
  magnitude_bits_ = bits - 1;
  magnitude_levels_ = (1u << magnitude_bits_) - 1;
  log_step_ = float(std::log2(1.0 + double(max_abs)) / magnitude_levels_);
  inverse_log_step_ = log_step_ > 0 ? 1.0 / double(log_step_) : 0.0;
}

std::uint32_t LogQuantizer::encode(float x) const {
  const std::uint32_t m = to_level(std::log2(1.0 + std::abs(double(x))) * inverse_log_step_, magnitude_levels_);
  return sign_magnitude(x, m, magnitude_bits_);
}


double LogQuantizer::error_bound(double x) const {
  return (1.0 + std::abs(x)) * (std::exp2(0.5 * double(log_step_)) - 1.0);
}

MuLawQuantizer::MuLawQuantizer(float max_abs, float mu, int bits) {
  check_bits(bits, 2, "MuLawQuantizer");
  check_max_abs(max_abs, "MuLawQuantizer");
  if (!std::isfinite(mu) || mu <= 0 || mu > 1e30f) {
    throw Error("MuLawQuantizer: mu must be in (0, 1e30], got " + std::to_string(mu));
  }
  magnitude_bits_ = bits - 1;
  magnitude_levels_ = (1u << magnitude_bits_) - 1;
  log_step_ = float(std::log2(1.0 + double(mu)) / magnitude_levels_);
  scale_ = float(double(max_abs) / double(mu));
  inverse_log_step_ = 1.0 / double(log_step_);
}

std::uint32_t MuLawQuantizer::encode(float x) const {
  const double relative = scale_ > 0 ? std::abs(double(x)) / double(scale_) : 0.0;  // mu |x| / xmax
  const std::uint32_t m = to_level(std::log2(1.0 + relative) * inverse_log_step_, magnitude_levels_);
  return sign_magnitude(x, m, magnitude_bits_);
}


double MuLawQuantizer::error_bound(double x) const {
  return (double(scale_) + std::abs(x)) * (std::exp2(0.5 * double(log_step_)) - 1.0);
}

}  // namespace strata::quant
