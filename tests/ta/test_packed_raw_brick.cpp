// The packed lossless brick (payload kind raw_packed, ta/raw_brick.hpp): decoding gives back the
// samples bit for bit whatever their coding, it stores only the box whose outside repeats its
// edge, and every forged header field is refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "strata/core/error.hpp"
#include "strata/ta/brick_codec.hpp"
#include "ta/raw_brick.hpp"
#include "ta/ta_test_util.hpp"

using namespace strata;
using namespace strata::ta;

namespace {

constexpr int kWidth = 16;
constexpr std::size_t kVoxels = std::size_t(kWidth) * kWidth * kWidth;

std::vector<float> decoded(std::span<const std::byte> payload) {
  std::vector<float> out(kVoxels);
  std::vector<std::byte> scratch;
  decode_packed_brick(payload, kWidth, out, scratch, "brick.strata");
  return out;
}

bool bit_equal(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

std::vector<float> uniform_integers(int lo, int hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(lo, hi);
  std::vector<float> v(kVoxels);
  for (float& x : v) x = float(d(rng));
  return v;
}

// A brick padded the way a level's edge pads it: the samples of `box` (lo, extent per axis),
// each coordinate outside it clamped to the box's edge.
std::vector<float> edge_padded(const std::vector<float>& inner, std::array<int, 3> lo, std::array<int, 3> extent) {
  std::vector<float> v(kVoxels);
  for (int k = 0; k < kWidth; ++k)
    for (int j = 0; j < kWidth; ++j)
      for (int i = 0; i < kWidth; ++i) {
        const int ci = std::clamp(i, lo[0], lo[0] + extent[0] - 1), cj = std::clamp(j, lo[1], lo[1] + extent[1] - 1),
                  ck = std::clamp(k, lo[2], lo[2] + extent[2] - 1);
        v[std::size_t(i + kWidth * (j + kWidth * k))] = inner[std::size_t(ci + kWidth * (cj + kWidth * ck))];
      }
  return v;
}

std::uint16_t header_u16(const std::vector<std::byte>& p, std::size_t offset) {
  std::uint16_t v;
  std::memcpy(&v, p.data() + offset, 2);
  return v;
}

}  // namespace

TEST(TaPackedRawBrick, EveryCodingDecodesBitForBit) {
  struct Case {
    std::vector<float> samples;
    int coding;  // the payload's first byte
  };
  std::vector<float> floats(kVoxels);
  std::mt19937 rng(3);
  std::normal_distribution<float> normal(0.0f, 1e3f);
  for (float& x : floats) x = normal(rng);
  std::vector<float> signed_zero = uniform_integers(-3, 3, 4);
  signed_zero[17] = -0.0f;  // integer-valued, but a code would bring it back as +0
  std::vector<float> beyond_exact = uniform_integers(0, 200, 5);
  beyond_exact[9] = 16777216.0f;  // 2^24: base + code is no longer exact in general
  std::vector<float> eighths = uniform_integers(0, 2040, 11);  // 2 x 2 x 2 means of u8 samples
  for (float& x : eighths) x /= 8;
  std::vector<float> tenths = eighths;
  tenths[100] = 0.1f;  // no power-of-two step holds it
  std::vector<float> past_u16 = uniform_integers(0, 65536, 7);
  past_u16[0] = 0;
  past_u16[1] = 65536;
  const std::vector<Case> cases = {
      {uniform_integers(0, 255, 1), 1},          // a u8 source
      {eighths, 2},                              // a coarser level: u16 codes of 1/8 steps
      {tenths, 0},
      {uniform_integers(-1024, 3071, 2), 2},     // CT in Hounsfield units: a u16 code above a negative base
      {uniform_integers(100000, 100255, 6), 1},  // a large offset with an 8-bit spread
      {past_u16, 0},                             // one past the u16 spread
      {floats, 0},
      {signed_zero, 0},
      {beyond_exact, 0},
  };
  for (const Case& c : cases) {
    const std::vector<std::byte> payload = encode_packed_brick(c.samples, kWidth, 3);
    EXPECT_EQ(int(payload[0]), c.coding);
    EXPECT_TRUE(bit_equal(decoded(payload), c.samples));
  }
}

TEST(TaPackedRawBrick, StoresOnlyTheBoxItsPaddingRepeats) {
  // A 5 x 1 x 9 corner of real samples, as a brick at the far edge of a thin level holds it.
  const std::array<int, 3> lo{2, 0, 7}, extent{5, 1, 9};
  const std::vector<float> brick = edge_padded(uniform_integers(0, 65535, 8), lo, extent);
  const std::vector<std::byte> payload = encode_packed_brick(brick, kWidth, 3);
  for (std::size_t a = 0; a < 3; ++a) {
    if (extent[a] > 1) {  // else any slice will do
      EXPECT_EQ(header_u16(payload, 2 + 2 * a), lo[a]) << "axis " << a;
    }
    EXPECT_EQ(header_u16(payload, 8 + 2 * a), extent[a]) << "axis " << a;
  }
  EXPECT_TRUE(bit_equal(decoded(payload), brick));
  // 45 random u16 samples: 90 bytes of codes, all the payload holds besides its 18-byte header
  // and the zstd frame's own overhead (under 20 bytes for so short a frame). zstd finds most of
  // the repetition in the whole padded brick too, but not all of it, nor the unused float bits.
  EXPECT_LE(payload.size(), 18u + 90u + 20u);
  EXPECT_LT(payload.size() * 2, encode_raw_brick(brick, 3).size());
}

// The encoder's steps report the sizes it then stores: the box, its codes at the chosen width
// (u16 for samples spanning 0..65535, u8 for 0..255, f32 for fractions no code holds), and the
// same payload as the one-call encoder.
TEST(TaPackedRawBrick, TheEncoderStepsReportWhatItStores) {
  const std::array<int, 3> lo{2, 0, 7}, extent{5, 1, 9};
  struct Case {
    std::vector<float> inner;
    std::size_t code_bytes;
  };
  std::vector<float> fractions = uniform_integers(0, 1000, 5);
  for (float& x : fractions) x = x / 1000.0f + 0.0001f;
  for (const Case& c : {Case{uniform_integers(0, 65535, 8), 2}, Case{uniform_integers(0, 255, 9), 1}, Case{fractions, 4}}) {
    const std::vector<float> brick = edge_padded(c.inner, lo, extent);
    PackedBrickEncoder encoder(brick, kWidth);
    EXPECT_EQ(encoder.box_voxels(), 45u);
    EXPECT_EQ(encoder.plain_bytes(), 45u * c.code_bytes);
    const std::vector<std::byte> payload = encoder.encode(3);
    EXPECT_EQ(payload, encode_packed_brick(brick, kWidth, 3));
    EXPECT_EQ(std::to_integer<int>(payload[0]), c.code_bytes == 4 ? 0 : c.code_bytes == 1 ? 1 : 2);
    EXPECT_TRUE(bit_equal(decoded(payload), brick));
  }
}

TEST(TaPackedRawBrick, ForgedHeadersAreRefusedByField) {
  const std::vector<std::byte> good = encode_packed_brick(uniform_integers(0, 255, 9), kWidth, 3);
  auto forged = [&](std::size_t offset, std::vector<std::uint8_t> bytes) {
    std::vector<std::byte> p = good;
    for (std::size_t i = 0; i < bytes.size(); ++i) p[offset + i] = std::byte(bytes[i]);
    return p;
  };
  const float nan = std::nanf("");
  std::uint8_t nan_bytes[4];
  std::memcpy(nan_bytes, &nan, 4);
  const std::vector<std::pair<std::vector<std::byte>, std::string>> cases = {
      {forged(0, {3}), "coding"},
      {forged(1, {9}), "fraction bits"},
      {forged(8, {0, 0}), "stored box"},               // extent 0 along x
      {forged(2, {10, 0}), "stored box"},              // lo 10 + extent 16 > 16
      {forged(12, {17, 0}), "stored box"},             // extent 17 along z
      {forged(14, {nan_bytes[0], nan_bytes[1], nan_bytes[2], nan_bytes[3]}), "base"},
      {std::vector<std::byte>(good.begin(), good.begin() + 10), "truncated"},
      {std::vector<std::byte>(good.begin(), good.end() - 3), "planes"},
  };
  for (const auto& [payload, field] : cases) {
    try {
      decoded(payload);
      ADD_FAILURE() << "accepted a payload forged in " << field;
    } catch (const FormatError& e) {
      EXPECT_NE(std::string(e.what()).find("brick.strata"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
  // A 2 x 2 x 2 box whose planes hold a whole brick's codes: the box decides, not the frame.
  std::vector<std::byte> wrong_size = forged(8, {2, 0, 2, 0, 2, 0});
  EXPECT_THROW(decoded(wrong_size), FormatError);
}

TEST(TaPackedRawBrick, TheFixedRankCodecStoresNoiseLosslesslyWhenThatIsSmaller) {
  // At rank 16 a width-16 brick of white u8 noise costs 16^3 core bytes plus 3 x 16^2 16-bit
  // factor codes (5.5 KiB, incompressible) against 4 KiB of u8 codes; a smooth float field at
  // rank 8 (512 core bytes, 768 factor codes) against ~3 bytes per float sample stays Tucker.
  CodecParams p;
  p.quant = quant::QuantScheme::parse("u16,b8log+");
  ASSERT_TRUE(p.lossless_fallback);  // the default
  tensor::Tensor3 noise(kWidth, kWidth, kWidth), smooth(kWidth, kWidth, kWidth);
  const std::vector<float> v = uniform_integers(0, 255, 10);
  std::copy(v.begin(), v.end(), noise.values().begin());
  for (std::size_t i = 0; i < kVoxels; ++i)
    smooth.values()[i] = std::sin(0.3f * float(i % kWidth)) * std::cos(0.2f * float(i / kWidth % kWidth)) +
                         0.1f * float(i / (kWidth * kWidth));
  p.rank = 16;
  const EncodedBrick n = encode_brick(noise, p);
  EXPECT_EQ(n.kind, store::PayloadKind::raw_packed);
  EXPECT_TRUE(bit_equal(decoded(n.payload), v));
  p.rank = 8;
  const EncodedBrick s = encode_brick(smooth, p);
  EXPECT_TRUE(s.kind == store::PayloadKind::tucker || s.kind == store::PayloadKind::tucker_zstd)
      << store::payload_kind_name(s.kind);
  p.rank = 16;
  p.lossless_fallback = false;
  EXPECT_NE(encode_brick(noise, p).kind, store::PayloadKind::raw_packed);
}
