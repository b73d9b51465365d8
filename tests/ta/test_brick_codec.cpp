// One brick <-> one payload: constant detection, the payload's parts, rank clamping at decode
// and the errors a damaged payload raises.
#include <gtest/gtest.h>

#include <random>

#include "strata/quant/brick.hpp"
#include "strata/ta/brick_codec.hpp"
#include "ta/ta_test_util.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;

namespace {

// A smooth field plus noise: full rank, dominated by a few components.
tensor::Tensor3 smooth_brick(int b, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  tensor::Tensor3 t(b, b, b);
  for (int k = 0; k < b; ++k)
    for (int j = 0; j < b; ++j)
      for (int i = 0; i < b; ++i) t(i, j, k) = 3.0f + std::sin(0.4f * i) * std::cos(0.3f * j) + 0.1f * k + noise(rng);
  return t;
}

CodecParams codec(int rank, const std::string& quant, int zstd = 0) {
  CodecParams p;
  p.rank = rank;
  p.quant = quant::QuantScheme::parse(quant);
  p.hooi_iterations = 3;
  p.zstd_level = zstd;
  p.lossless_fallback = false;  // the Tucker bricks themselves (test_packed_raw_brick.cpp has the fallback)
  return p;
}

std::vector<float> decode(const EncodedBrick& e, const CodecParams& p, int b, int k) {
  tensor::BrickReconstructor r;
  DecodeScratch s;
  std::vector<float> out(std::size_t(b) * b * b);
  decode_brick(e.kind, e.payload, e.constant_value, p.quant, b, k, r, s, out, "test");
  return out;
}

}  // namespace

TEST(TaBrickCodec, ConstantBrickHasNoPayloadAndDecodesToItsValue) {
  tensor::Tensor3 t(8, 8, 8);
  for (float& v : t.values()) v = -2.5f;
  const CodecParams p = codec(4, "u16,b8log+");
  const EncodedBrick e = encode_brick(t, p);
  EXPECT_EQ(e.kind, store::PayloadKind::constant);
  EXPECT_TRUE(e.payload.empty());
  EXPECT_EQ(e.constant_value, -2.5f);
  EXPECT_EQ(e.core_bytes + e.factor_bytes + e.header_bytes, 0u);
  for (float v : decode(e, p, 8, 4)) ASSERT_EQ(v, -2.5f);
  // One differing voxel makes it a tensor brick.
  t(7, 7, 7) = -2.4f;
  EXPECT_EQ(encode_brick(t, p).kind, store::PayloadKind::tucker);
  EXPECT_TRUE(is_tucker(encode_brick(t, codec(4, "u16,b8log+", 3)).kind));
}

TEST(TaBrickCodec, PayloadPartsFollowThePaperStorageFormula) {
  // Paper 1 §4.2: R^3 core codes + 3 B R factor codes + a few floats.
  // u16,b8log+ at B = 8, R = 4: 12 header bytes + factor lo/hi, core max|b| and hot corner
  // (4 floats) = 28; 64 one-byte core codes; 96 two-byte factor codes = 192 bytes.
  const CodecParams p = codec(4, "u16,b8log+");
  const EncodedBrick e = encode_brick(smooth_brick(8, 1), p);
  ASSERT_EQ(e.kind, store::PayloadKind::tucker);
  EXPECT_EQ(e.core_bytes, 64u);
  EXPECT_EQ(e.factor_bytes, 192u);
  EXPECT_EQ(e.header_bytes, 28u);
  EXPECT_EQ(e.payload.size(), 28u + 64u + 192u);
  const PayloadParts parts = payload_parts(e.payload, p.quant, "x");
  EXPECT_EQ(parts.core_bytes, e.core_bytes);
  EXPECT_EQ(parts.factor_bytes, e.factor_bytes);
  EXPECT_EQ(parts.header_bytes, e.header_bytes);
  // f32 at the same size: 12 + 4 * 64 + 4 * 96.
  const EncodedBrick f = encode_brick(smooth_brick(8, 1), codec(4, "f32"));
  EXPECT_EQ(f.payload.size(), 12u + 256u + 384u);
}

TEST(TaBrickCodec, FullRankFloatIsExactAndLowerRanksDegradeMonotonically) {
  const tensor::Tensor3 t = smooth_brick(8, 2);
  const CodecParams p = codec(8, "f32");
  const EncodedBrick e = encode_brick(t, p);
  auto err = [&](int k) {
    const auto d = decode(e, p, 8, k);
    double s = 0;
    for (std::size_t i = 0; i < d.size(); ++i) s += (d[i] - t.values()[i]) * double(d[i] - t.values()[i]);
    return std::sqrt(s / double(d.size()));
  };
  EXPECT_LT(err(8), 1e-5);  // values ~4: a few float ulps
  EXPECT_LT(err(8), err(6));
  EXPECT_LT(err(6), err(3));
  EXPECT_LT(err(3), err(1));
  EXPECT_EQ(decode(e, p, 8, 8), decode(e, p, 8, 100));  // K above the stored rank clamps
}

TEST(TaBrickCodec, DecodeErrorsNameTheContext) {
  const CodecParams p = codec(4, "u16,b8log+");
  const EncodedBrick e = encode_brick(smooth_brick(8, 3), p);
  tensor::BrickReconstructor r;
  DecodeScratch s;
  std::vector<float> out(512), small(100), wide(10 * 10 * 10);
  auto msg = [&](store::PayloadKind kind, std::span<const std::byte> payload, int width, std::span<float> o) {
    return error_of([&] { decode_brick(kind, payload, 0, p.quant, width, 4, r, s, o, "brick (level 0, 1,2,3)"); });
  };
  EXPECT_EQ(msg(e.kind, e.payload, 8, out), "");
  // Buffer of the wrong size.
  EXPECT_TRUE(contains(msg(e.kind, e.payload, 8, small), "brick (level 0, 1,2,3)"));
  // Payload made for another brick width.
  const std::string w = msg(e.kind, e.payload, 10, wide);
  EXPECT_TRUE(contains(w, "brick (level 0, 1,2,3)")) << w;
  EXPECT_TRUE(contains(w, "10")) << w;
  // Truncated and extended payloads (the byte count must match the scheme exactly).
  const std::span<const std::byte> cut(e.payload.data(), e.payload.size() - 1);
  EXPECT_TRUE(contains(msg(e.kind, cut, 8, out), "brick (level 0, 1,2,3)"));
  std::vector<std::byte> longer = e.payload;
  longer.push_back(std::byte{0});
  EXPECT_TRUE(contains(msg(e.kind, longer, 8, out), "brick (level 0, 1,2,3)"));
  EXPECT_TRUE(contains(msg(e.kind, {}, 8, out), "brick (level 0, 1,2,3)"));
  // A payload kind this codec does not know.
  EXPECT_TRUE(contains(msg(store::PayloadKind(9), e.payload, 8, out), "brick (level 0, 1,2,3)"));
  EXPECT_TRUE(contains(error_of([&] { payload_parts(cut, p.quant, "eval ctx"); }), "eval ctx"));
}

TEST(TaBrickCodec, ZstdStageIsLosslessAndItsPartsAddUp) {
  const tensor::Tensor3 t = smooth_brick(16, 4);
  const CodecParams plain_params = codec(8, "u16,b8log+", 0), zstd_params = codec(8, "u16,b8log+", 3);
  const EncodedBrick plain = encode_brick(t, plain_params), packed = encode_brick(t, zstd_params);
  ASSERT_EQ(plain.kind, store::PayloadKind::tucker);
  ASSERT_EQ(packed.kind, store::PayloadKind::tucker_zstd);
  EXPECT_LT(packed.payload.size(), plain.payload.size());
  EXPECT_EQ(packed.core_bytes + packed.factor_bytes + packed.header_bytes, packed.payload.size());
  // Inflating gives back the plain quantized brick, byte for byte.
  DecodeScratch s;
  const auto inflated = plain_payload(packed.kind, packed.payload, zstd_params.quant, s, "ctx");
  EXPECT_TRUE(std::equal(inflated.begin(), inflated.end(), plain.payload.begin(), plain.payload.end()));
  const auto same = plain_payload(plain.kind, plain.payload, plain_params.quant, s, "ctx");
  EXPECT_EQ(same.data(), plain.payload.data());  // plain payloads pass through without a copy
  for (int k : {8, 3}) EXPECT_EQ(decode(plain, plain_params, 16, k), decode(packed, zstd_params, 16, k)) << k;
  // A damaged zstd frame is an Error naming the context (never a crash or silent garbage).
  for (std::size_t at : {std::size_t(0), std::size_t(5), packed.payload.size() / 2, packed.payload.size() - 1}) {
    std::vector<std::byte> bad = packed.payload;
    bad[at] ^= std::byte{0xff};
    tensor::BrickReconstructor r;
    DecodeScratch s2;
    std::vector<float> out(16 * 16 * 16);
    const std::string msg = error_of([&] {
      decode_brick(packed.kind, bad, 0, zstd_params.quant, 16, 8, r, s2, out, "brick (level 1, 0,0,0)");
    });
    // zstd frames carry no checksum by default: a flipped byte in the middle may inflate to
    // other valid-looking bytes. The container's CRC-32C catches those; here only a clean
    // outcome is required: either an error with the context or a successful decode.
    if (!msg.empty()) {
      EXPECT_TRUE(contains(msg, "brick (level 1, 0,0,0)")) << at << ": " << msg;
    }
  }
  const std::span<const std::byte> cut(packed.payload.data(), packed.payload.size() / 2);
  EXPECT_TRUE(contains(error_of([&] { plain_payload(packed.kind, cut, zstd_params.quant, s, "ctx9"); }), "ctx9"));
}
