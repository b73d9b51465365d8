// Bulk code decoding (src/quant/decode_kernel.cpp) at every instruction-set level it is
// compiled for, against the generic variant.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "strata/quant/brick.hpp"
#include "strata/tensor/tucker.hpp"
#include "support/isa_test.hpp"

namespace strata::quant {
namespace {

// Every coding and width the decoder handles: f32, linear, log and mu-law cores of 8, 12 and
// 16 bits, 8-bit, 16-bit and float factors.
const char* const kSchemes[] = {"f32",        "u16,b8log+",   "u16,b8log", "u8,b8lin",  "u16,b16lin",
                                "u16,b12log+", "u16,b8mu+",    "u8,b12mu1000", "u16,b16log", "f32,b8lin+",
                                "u16,b12lin"};

tensor::Tucker signed_brick_model(int b, int r, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  tensor::Tensor3 a(b, b, b);
  for (int k = 0; k < b; ++k)
    for (int j = 0; j < b; ++j)
      for (int i = 0; i < b; ++i)
        a(i, j, k) = 50.0f * std::sin(0.4f * float(i) - 0.25f * float(j) + 0.3f * float(k)) + noise(rng);
  return tensor::hooi(a, {r, r, r});
}

struct Decoded {
  std::vector<float> core;
  std::vector<std::vector<float>> factors;
};

Decoded decode_under(Isa isa, const BrickView& view, const tensor::Ranks3& leading) {
  const ScopedIsaLimit limit(isa);
  Decoded d;
  d.core.resize(std::size_t(leading[0]) * std::size_t(leading[1]) * std::size_t(leading[2]));
  view.dequantize_core(leading, d.core);
  for (int mode = 1; mode <= 3; ++mode) {
    d.factors.emplace_back(std::size_t(view.dims()[std::size_t(mode - 1)]) * std::size_t(leading[std::size_t(mode - 1)]));
    view.dequantize_factor(mode, leading[std::size_t(mode - 1)], d.factors.back());
  }
  return d;
}

}  // namespace

// The FMA builds may contract a multiply-add that the generic build rounds twice, so decoded
// values may differ by a few ulps. Linear codes (lo + c step) differ by at most one rounding of
// c step: u (|x| + |lo|). Log and mu-law codes evaluate 2^t as 2^n p(f), p a degree-7 Horner
// polynomial with |f| <= 1/2 and positive coefficients: 7 steps, each differing by at most one
// rounding of p f (<= u 2^(1/2) / 2), add at most 5 u 2^t; then -1 and the scale are the same
// operations. So every difference is within 8 u (|x| + m), m the largest decoded magnitude of
// the array (which bounds |lo|, the mu-law scale and the log curve's +1 for any m >= 1).
void expect_within_contraction(const std::vector<float>& wide, const std::vector<float>& generic) {
  ASSERT_EQ(wide.size(), generic.size());
  float m = 1;
  for (float x : generic) m = std::max(m, std::abs(x));
  const double u = std::ldexp(1.0, -24);
  for (std::size_t i = 0; i < wide.size(); ++i)
    ASSERT_NEAR(wide[i], generic[i], 8 * u * (std::abs(double(generic[i])) + m)) << i;
}

class QuantDecodePerIsa : public test::IsaTest {};

TEST_P(QuantDecodePerIsa, AgreesWithTheGenericDecodeToRounding) {
  // The full ranks merge rows into one long run; leading ranks below them decode row by row
  // with vector tails (R = 13 is no multiple of any vector width).
  const tensor::Tucker model = signed_brick_model(24, 13, 11);
  for (const char* text : kSchemes) {
    const QuantScheme scheme = QuantScheme::parse(text);
    const std::vector<std::byte> bytes = serialize(quantize(model, scheme), scheme);
    const BrickView view(bytes, scheme);
    for (const tensor::Ranks3& leading : {tensor::Ranks3{13, 13, 13}, tensor::Ranks3{13, 13, 5}, tensor::Ranks3{7, 3, 11}, tensor::Ranks3{1, 1, 1}}) {
      SCOPED_TRACE(std::string(text) + " K=" + std::to_string(leading[0]) + "," + std::to_string(leading[1]) + "," +
                   std::to_string(leading[2]));
      const Decoded wide = decode_under(isa(), view, leading), generic = decode_under(Isa::generic, view, leading);
      expect_within_contraction(wide.core, generic.core);
      for (std::size_t n = 0; n < 3; ++n) expect_within_contraction(wide.factors[n], generic.factors[n]);
      if (scheme.hot_corner_float || scheme.core_coding == CoreCoding::f32) {
        EXPECT_EQ(wide.core[0], generic.core[0]);  // stored as a float: restored exactly
      }
    }
  }
}

STRATA_INSTANTIATE_PER_ISA(QuantDecodePerIsa, Isa::avx2, Isa::avx512);

}  // namespace strata::quant
