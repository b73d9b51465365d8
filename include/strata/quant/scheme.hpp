#pragma once
/// @file
/// @brief How the factor matrices and the core tensor of a brick are quantized (paper 1, §4.1 and §6.2).
/// Spelled like the paper's figure labels: "<factors>,<core>", e.g. "u16,b8log+" =
/// 16-bit linear factors (Eq. 1), 8-bit logarithmic core (Eq. 2, sign bit + 7 magnitude bits) and
/// the hot-corner coefficient B(0,0,0) kept as a float. See QuantScheme::parse for the grammar.
#include <cstdint>
#include <string>
#include <string_view>

namespace strata::quant {

/// @brief How the three factor matrices are stored.
enum class FactorCoding : std::uint8_t {
  f32,     // raw IEEE float
  linear,  // Eq. 1 with one min/max pair shared by U1, U2, U3
};

/// @brief How the core coefficients are stored.
enum class CoreCoding : std::uint8_t {
  f32,     // raw IEEE float
  linear,  // Eq. 1 over the core's own min/max
  log,     // Eq. 2: sign bit + round(M log2(1 + |x|) / log2(1 + xmax)), M = 2^(bits-1) - 1
  mulaw,   // scale-invariant: sign bit + round(M log2(1 + mu |x| / xmax) / log2(1 + mu))
};

/// @brief A parsed `--quant` scheme: the factors' coding and bits, the core's, the hot corner, mu.
struct QuantScheme {
  static constexpr float kDefaultMu = 255.0f;

  FactorCoding factor_coding = FactorCoding::linear;
  int factor_bits = 16;  // 8 or 16 (32 for f32)
  CoreCoding core_coding = CoreCoding::log;
  int core_bits = 8;     // bits per core code, sign included: 8, 12 or 16 (32 for f32)
  bool hot_corner_float = true;  // the "+" variants: B(0,0,0) stored as float, its slot coded 0
  float mu = kDefaultMu;         // mulaw only; stored in each brick

  /// @brief Grammar (case-sensitive):
  ///   "f32"                         everything as float
  ///   <factors> "," <core>
  ///   <factors> := "u8" | "u16" | "f32"
  ///   <core>    := "f32" | "b" <8|12|16> <kind> ["+"]
  ///   <kind>    := "lin" | "log" | "mu" [<mu, a positive number; default 255>]
  /// Examples: "u16,b8log+", "u16,b8log", "u8,b8lin", "u16,b16lin", "u16,b12log+", "u16,b8mu+",
  /// "u16,b8mu1000+". Throws Error naming the text and the valid forms otherwise.
  static QuantScheme parse(std::string_view text);
  /// @brief Canonical spelling; parse(to_string()) == *this.
  std::string to_string() const;

  bool operator==(const QuantScheme&) const = default;
};

}  // namespace strata::quant
