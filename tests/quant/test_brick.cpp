#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "strata/core/error.hpp"
#include "strata/quant/bitpack.hpp"
#include "strata/quant/brick.hpp"
#include "strata/quant/quantizers.hpp"
#include "strata/tensor/ttm.hpp"

namespace strata::quant {
namespace {

const char* const kSchemes[] = {"f32",        "u16,b8log+", "u16,b8log", "u8,b8lin",  "u16,b16lin",
                                "u16,b12log+", "u16,b8mu+",  "u8,b12mu1000", "u16,b16log", "f32,b8lin+"};

// A scan-like brick (positive, smooth, some texture) and its rank-R HOOI model.
tensor::Tucker brick_model(int b, int r, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 2.0f);
  tensor::Tensor3 a(b, b, b);
  for (int k = 0; k < b; ++k)
    for (int j = 0; j < b; ++j)
      for (int i = 0; i < b; ++i) {
        const double r2 = (i - 0.4 * b) * (i - 0.4 * b) + (j - 0.5 * b) * (j - 0.5 * b) + (k - 0.6 * b) * (k - 0.6 * b);
        a(i, j, k) = float(900.0 + 600.0 * std::exp(-r2 / (0.1 * b * b)) + 80.0 * std::sin(0.5 * i - 0.3 * j + 0.2 * k)) +
                     noise(rng);
      }
  return tensor::hooi(a, {r, r, r});
}

double max_abs(std::span<const float> v) {
  double m = 0;
  for (float x : v) m = std::max(m, double(std::abs(x)));
  return m;
}

TEST(QuantQuantizedBrick, SerializedSizeFollowsPaperSection42) {
  const QuantScheme s = QuantScheme::parse("u16,b8log+");
  // R^3 Q_B + 3 B R Q_U bits, + floats: factor min/max, core max, hot corner, + 12-byte header.
  EXPECT_EQ(serialized_size(s, {32, 32, 32}, {16, 16, 16}), 12u + 4 * 4 + 4096 + 3 * 32 * 16 * 2);
  EXPECT_EQ(serialized_size(QuantScheme::parse("u16,b12log+"), {32, 32, 32}, {16, 16, 16}),
            12u + 4 * 4 + 4096 * 3 / 2 + 3 * 32 * 16 * 2);
  EXPECT_EQ(serialized_size(QuantScheme::parse("f32"), {32, 32, 32}, {16, 16, 16}), 12u + 4096 * 4 + 3 * 32 * 16 * 4);
  EXPECT_EQ(serialized_size(QuantScheme::parse("u8,b8mu"), {8, 8, 8}, {3, 3, 3}), 12u + 4 * 4 + 27 + 3 * 8 * 3);
}

TEST(QuantQuantizedBrick, SerializationRoundTripsForEveryScheme) {
  const tensor::Tucker model = brick_model(16, 8, 1);
  for (const char* text : kSchemes) {
    SCOPED_TRACE(text);
    const QuantScheme s = QuantScheme::parse(text);
    const QuantizedBrick q = quantize(model, s);
    const std::vector<std::byte> bytes = serialize(q, s);
    EXPECT_EQ(bytes.size(), serialized_size(s, q.dims, q.ranks));
    EXPECT_EQ(deserialize(bytes, s), q);
  }
}

// The global-basis codec's core-only bricks: the same core codes and parameters as the full
// brick of the same model, no factor codes, and a view that refuses to decode factors.
TEST(QuantQuantizedBrick, CoreOnlyBricksCarryTheCoreAlone) {
  const tensor::Tucker model = brick_model(16, 8, 3);
  for (const char* text : kSchemes) {
    SCOPED_TRACE(text);
    const QuantScheme s = QuantScheme::parse(text);
    const QuantizedBrick full = quantize(model, s), core = quantize_core_only(model.core, s);
    EXPECT_EQ(core.dims, (tensor::Dims3{0, 0, 0}));
    EXPECT_EQ(core.ranks, full.ranks);
    EXPECT_EQ(core.core_codes, full.core_codes);
    EXPECT_TRUE(core.factor_codes.empty());
    const std::vector<std::byte> bytes = serialize(core, s);
    EXPECT_EQ(bytes.size(), serialized_size(s, full.dims, full.ranks) - packed_size(full.factor_codes.size(), s.factor_bits));
    EXPECT_EQ(deserialize(bytes, s), core);
    const BrickView view(bytes, s);
    DequantizedModel m;
    dequantize(view, {5, 6, 7}, m);
    std::vector<float> expected(5 * 6 * 7);
    BrickView(serialize(full, s), s).dequantize_core({5, 6, 7}, expected);
    EXPECT_EQ(m.core, expected);
    EXPECT_TRUE(m.factors[0].empty());
    EXPECT_THROW(view.dequantize_factor(1, 1, {}), Error);
  }
}

TEST(QuantQuantizedBrick, FloatSchemeIsLossless) {
  const tensor::Tucker model = brick_model(16, 8, 2);
  const QuantScheme s = QuantScheme::parse("f32");
  const tensor::Tucker back = dequantize(quantize(model, s), s);
  EXPECT_EQ(back.core, model.core);
  for (std::size_t n = 0; n < 3; ++n) EXPECT_EQ(back.factors[n], model.factors[n]);
}

TEST(QuantQuantizedBrick, HotCornerIsExactInPlusSchemes) {
  const tensor::Tucker model = brick_model(16, 8, 3);
  for (const char* text : {"u16,b8log+", "u16,b12log+", "u16,b8mu+", "u8,b8lin+"}) {
    const QuantScheme s = QuantScheme::parse(text);
    const QuantizedBrick q = quantize(model, s);
    EXPECT_EQ(q.params.hot_corner, model.core(0, 0, 0)) << text;
    EXPECT_EQ(dequantize(q, s).core(0, 0, 0), model.core(0, 0, 0)) << text;
    // The hot corner is excluded from the coded range, so the range is that of the rest.
    if (s.core_coding != CoreCoding::linear) {
      EXPECT_EQ(q.params.core_max_abs, float(max_abs(model.core.values().subspan(1)))) << text;
    }
  }
}

TEST(QuantQuantizedBrick, FactorErrorIsWithinHalfAStep) {
  const tensor::Tucker model = brick_model(16, 8, 4);
  for (const char* text : {"u8,b8log", "u16,b8log"}) {
    const QuantScheme s = QuantScheme::parse(text);
    const QuantizedBrick q = quantize(model, s);
    const LinearQuantizer lin(q.params.factor_lo, q.params.factor_hi, s.factor_bits);
    const tensor::Tucker back = dequantize(q, s);
    const double slack = 4 * 0x1p-23 * std::max(std::abs(q.params.factor_lo), std::abs(q.params.factor_hi));
    for (std::size_t n = 0; n < 3; ++n) {
      EXPECT_LE((back.factors[n] - model.factors[n]).cwiseAbs().maxCoeff(), lin.max_error() + slack) << text;
    }
  }
}

TEST(QuantQuantizedBrick, CoreErrorIsWithinEachCodingsBound) {
  const tensor::Tucker model = brick_model(16, 8, 5);
  const auto core = model.core.values();
  for (const char* text : {"u16,b8log+", "u16,b8log", "u16,b12log+", "u16,b16log", "u16,b8mu+", "u16,b16lin"}) {
    SCOPED_TRACE(text);
    const QuantScheme s = QuantScheme::parse(text);
    const QuantizedBrick q = quantize(model, s);
    const tensor::Tucker back = dequantize(q, s);
    const auto& p = q.params;
    for (std::size_t i = s.hot_corner_float ? 1 : 0; i < core.size(); ++i) {
      const double x = core[i], err = std::abs(double(back.core.data()[i]) - x);
      double bound = 0;
      if (s.core_coding == CoreCoding::log) {
        bound = LogQuantizer(p.core_max_abs, s.core_bits).error_bound(x);
        bound += (1 + std::abs(x)) * (0.7 * 0x1p-24 * std::log2(1.0 + p.core_max_abs) + 4 * 0x1p-23);
      } else if (s.core_coding == CoreCoding::mulaw) {
        const MuLawQuantizer mq(p.core_max_abs, p.mu, s.core_bits);
        bound = mq.error_bound(x) + (mq.scale() + std::abs(x)) * (0.7 * 0x1p-24 * std::log2(1.0 + p.mu) + 6 * 0x1p-23);
      } else {
        bound = LinearQuantizer(p.core_lo, p.core_hi, s.core_bits).max_error() +
                4 * 0x1p-23 * std::max(std::abs(p.core_lo), std::abs(p.core_hi));
      }
      ASSERT_LE(err, bound) << "coefficient " << i << " = " << x;
      // Sign-magnitude codes never flip a sign; Eq. 1's affine grid need not contain 0.
      if (s.core_coding != CoreCoding::linear) {
        ASSERT_GE(x * double(back.core.data()[i]), 0.0) << "sign flipped at " << i;
      }
    }
  }
}

// Orthonormal factors make the core error the reconstruction error (‖Ã - Ã'‖ = ‖B - B'‖), so the
// hot corner's own resolution matters: taking it out of the log range must not hurt.
TEST(QuantQuantizedBrick, HotCornerVariantIsAtLeastAsAccurate) {
  const tensor::Tucker model = brick_model(16, 8, 6);
  auto core_error = [&](const char* text) {
    const QuantScheme s = QuantScheme::parse(text);
    const tensor::Tucker back = dequantize(quantize(model, s), s);
    double sum = 0;
    for (std::int64_t i = 0; i < model.core.size(); ++i) {
      const double d = double(back.core.data()[i]) - double(model.core.data()[i]);
      sum += d * d;
    }
    return std::sqrt(sum);
  };
  EXPECT_LE(core_error("u16,b8log+"), core_error("u16,b8log"));
  EXPECT_LE(core_error("u16,b8mu+"), core_error("u16,b8mu"));
  EXPECT_LT(core_error("u16,b16lin"), core_error("u16,b8lin"));
}

TEST(QuantBrickView, LeadingRanksEqualTruncatedFullDequantization) {
  const tensor::Tucker model = brick_model(16, 8, 7);
  for (const char* text : {"u16,b8log+", "u16,b12log+", "u8,b8lin", "f32"}) {
    SCOPED_TRACE(text);
    const QuantScheme s = QuantScheme::parse(text);
    const QuantizedBrick q = quantize(model, s);
    const std::vector<std::byte> bytes = serialize(q, s);
    const tensor::Tucker full = dequantize(q, s);
    const tensor::Tucker expected = truncate(full, {5, 3, 7});
    DequantizedModel out;
    dequantize(BrickView(bytes, s), {5, 3, 7}, out);
    EXPECT_TRUE(std::equal(out.core.begin(), out.core.end(), expected.core.values().begin()));
    for (std::size_t n = 0; n < 3; ++n) {
      EXPECT_TRUE(std::equal(out.factors[n].begin(), out.factors[n].end(), expected.factors[n].data()));
    }
  }
}

TEST(QuantBrickView, DecodesIntoBrickReconstructor) {
  const tensor::Tucker model = brick_model(32, 16, 8);
  const QuantScheme s = QuantScheme::parse("u16,b8log+");
  const QuantizedBrick q = quantize(model, s);
  const std::vector<std::byte> bytes = serialize(q, s);
  DequantizedModel decoded;
  dequantize(BrickView(bytes, s), {16, 16, 16}, decoded);
  tensor::BrickReconstructor rec;
  tensor::Tensor3 out(32, 32, 32);
  rec.reconstruct(decoded.view(), out.values());
  const tensor::Tucker full = dequantize(q, s);
  const tensor::Tensor3 expected = reconstruct(full.core, full.factors);
  double worst = 0;
  for (std::int64_t i = 0; i < out.size(); ++i) worst = std::max(worst, double(std::abs(out.data()[i] - expected.data()[i])));
  EXPECT_LT(worst, 1e-5 * full.core.norm());  // float rounding of two evaluation orders
}

TEST(QuantBrickView, RejectsWrongSizesHeadersAndSchemes) {
  const tensor::Tucker model = brick_model(8, 4, 9);
  const QuantScheme s = QuantScheme::parse("u16,b8log+");
  std::vector<std::byte> bytes = serialize(quantize(model, s), s);
  EXPECT_NO_THROW(BrickView(bytes, s));
  EXPECT_THROW(BrickView(std::span(bytes).first(bytes.size() - 1), s), FormatError);
  EXPECT_THROW(BrickView(std::span(bytes).first(5), s), FormatError);
  std::vector<std::byte> longer = bytes;
  longer.push_back(std::byte(0));
  EXPECT_THROW(BrickView(longer, s), FormatError);
  EXPECT_THROW(BrickView(bytes, QuantScheme::parse("u16,b16log+")), FormatError);  // size differs
  std::vector<std::byte> bad_rank = bytes;
  bad_rank[6] = std::byte(9);  // R1 = 9 > I1 = 8
  EXPECT_THROW(BrickView(bad_rank, s), Error);
  std::vector<std::byte> bad_range = bytes;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(bad_range.data() + 12, &nan, 4);  // factor_lo
  EXPECT_THROW(BrickView(bad_range, s), Error);
  const BrickView view(bytes, s);
  std::vector<float> wrong(10);
  EXPECT_THROW(view.dequantize_core({2, 2, 2}, wrong), Error);
  EXPECT_THROW(view.dequantize_factor(4, 2, wrong), Error);
}

TEST(QuantQuantizedBrick, RejectsNonFiniteCoefficients) {
  tensor::Tucker model = brick_model(8, 4, 10);
  model.core(1, 0, 0) = std::numeric_limits<float>::infinity();
  EXPECT_THROW(quantize(model, QuantScheme{}), Error);
}

TEST(QuantQuantizedBrick, RankOneCoreWithHotCornerHasNothingElseToCode) {
  tensor::Tucker model = brick_model(8, 1, 11);
  const QuantScheme s = QuantScheme::parse("u16,b8log+");
  const QuantizedBrick q = quantize(model, s);
  EXPECT_EQ(q.params.core_max_abs, 0.0f);
  EXPECT_EQ(dequantize(q, s).core(0, 0, 0), model.core(0, 0, 0));
}

}  // namespace
}  // namespace strata::quant
