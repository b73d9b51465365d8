// The adaptive binary range coder and its Exp-Golomb integers (strata/core/range_coder.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/core/range_coder.hpp"
#include "support/test_support.hpp"

using namespace strata;
using strata::test::error_of;

namespace {

const std::string kTruncated = "in.strata: coefficients: range-coded stream ends early (truncated)";

std::vector<int> bernoulli_bits(double p1, std::size_t count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution one(p1);
  std::vector<int> bits(count);
  for (int& b : bits) b = one(rng) ? 1 : 0;
  return bits;
}

std::vector<std::byte> encode_bits(const std::vector<int>& bits) {
  RangeEncoder enc;
  BitModel m;
  for (int b : bits) enc.encode_bit(m, b);
  return enc.finish();
}

// Decodes bits.size() bits with one model, returns them; finish_check() must pass.
std::vector<int> decode_bits(std::span<const std::byte> stream, std::size_t count) {
  RangeDecoder dec(stream, "in.strata", "coefficients");
  BitModel m;
  std::vector<int> bits(count);
  for (int& b : bits) b = dec.decode_bit(m);
  dec.finish_check();
  return bits;
}

// Values every Exp-Golomb prefix length meets at both of its ends, and random ones of every length.
std::vector<std::uint32_t> edge_and_random_uints(unsigned seed) {
  std::vector<std::uint32_t> values{0, 1, 2, 0xFFFFFFFEu, 0x7FFFFFFFu, 0x80000000u};
  for (int k = 1; k <= 31; ++k) {
    const std::uint32_t p = std::uint32_t(1) << k;
    values.insert(values.end(), {p - 2, p - 1, p});
  }
  std::mt19937_64 rng(seed);
  for (int i = 0; i < 2000; ++i) {
    const int width = int(rng() % 32);
    values.push_back(std::uint32_t(rng() & ((std::uint64_t(1) << width) - 1)));
  }
  return values;
}

// Codes `values` with encode(enc, model, v), decodes them with decode(dec, model) and a fresh
// model; every value must come back and finish_check() pass.
template <typename T, typename Encode, typename Decode>
void expect_round_trip(const std::vector<T>& values, Encode encode, Decode decode) {
  RangeEncoder enc;
  UIntModel em;
  for (T v : values) encode(enc, em, v);
  const std::vector<std::byte> stream = enc.finish();
  RangeDecoder dec(stream, "in.strata", "coefficients");
  UIntModel dm;
  for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(decode(dec, dm), values[i]) << "value " << i;
  EXPECT_NO_THROW(dec.finish_check());
}

}  // namespace

TEST(CoreRangeCoder, BitsRoundTripAtSkewedAndUniformProbabilities) {
  for (double p1 : {0.001, 0.01, 0.1, 0.5, 0.9, 0.999}) {
    const std::vector<int> bits = bernoulli_bits(p1, 200000, 17);
    EXPECT_EQ(decode_bits(encode_bits(bits), bits.size()), bits) << "p1 = " << p1;
  }
}

TEST(CoreRangeCoder, MillionsOfProbableBitsRoundTrip) {
  // A highly probable 1 adds a sliver to `low` on every bit: thousands of carries, some through a 0xFF byte.
  const std::vector<int> bits = bernoulli_bits(0.999, 4000000, 23);
  const std::vector<std::byte> stream = encode_bits(bits);
  EXPECT_LT(stream.size(), 12000u);  // ~ 0.016 bits a bit
  EXPECT_EQ(decode_bits(stream, bits.size()), bits);
}

TEST(CoreRangeCoder, ACarryRunsBackThroughThousandsOfFFBytes) {
  // Bits decoded from 0x12 0x80 00 00 ... keep the coding interval around that value, so the
  // encoder writes 0x12 0x7F FF FF ... until a final carry turns them into the original bytes.
  std::vector<std::byte> target(20000, std::byte{0});
  target[0] = std::byte{0x12};
  target[1] = std::byte{0x80};
  RangeDecoder steer(target, "target", "bits");
  std::vector<std::uint32_t> bits(100000);
  for (std::uint32_t& b : bits) b = steer.decode_bypass(1);
  RangeEncoder enc;
  for (std::uint32_t b : bits) enc.encode_bypass(b, 1);
  const std::vector<std::byte> stream = enc.finish();
  ASSERT_GT(stream.size(), 12000u);
  EXPECT_TRUE(std::equal(stream.begin(), stream.end(), target.begin()));
  RangeDecoder dec(stream, "in.strata", "coefficients");
  for (std::size_t i = 0; i < bits.size(); ++i) ASSERT_EQ(dec.decode_bypass(1), bits[i]) << i;
  EXPECT_NO_THROW(dec.finish_check());
}

TEST(CoreRangeCoder, MixedBypassAndAdaptiveStreamsRoundTrip) {
  struct Symbol {
    int model;  // -1: bypass
    std::uint32_t value;
    int bits;
  };
  std::mt19937_64 rng(29);
  std::vector<Symbol> symbols;
  for (int i = 0; i < 100000; ++i) {
    const int kind = int(rng() % 5);
    if (kind < 4) {
      // Four models, each with its own skew (p1 = 0.02, 0.2, 0.5, 0.95).
      const double p1 = std::array{0.02, 0.2, 0.5, 0.95}[std::size_t(kind)];
      symbols.push_back({kind, std::uint32_t(std::bernoulli_distribution(p1)(rng)), 1});
    } else {
      const int bits = int(rng() % 33);  // 0..32
      symbols.push_back({-1, bits == 0 ? 0u : std::uint32_t(rng() >> (64 - bits)), bits});
    }
  }
  RangeEncoder enc;
  std::array<BitModel, 4> em{};
  for (const Symbol& s : symbols)
    s.model < 0 ? enc.encode_bypass(s.value, s.bits) : enc.encode_bit(em[std::size_t(s.model)], int(s.value));
  const std::vector<std::byte> stream = enc.finish();
  RangeDecoder dec(stream, "in.strata", "coefficients");
  std::array<BitModel, 4> dm{};
  for (std::size_t i = 0; i < symbols.size(); ++i) {
    const Symbol& s = symbols[i];
    const std::uint32_t got =
        s.model < 0 ? dec.decode_bypass(s.bits) : std::uint32_t(dec.decode_bit(dm[std::size_t(s.model)]));
    ASSERT_EQ(got, s.value) << "symbol " << i;
  }
  EXPECT_NO_THROW(dec.finish_check());
  for (std::size_t k = 0; k < em.size(); ++k) EXPECT_EQ(dm[k].p0, em[k].p0) << "model " << k;
}

TEST(CoreRangeCoder, UnsignedIntegersRoundTripUpToTwoPow32MinusTwo) {
  expect_round_trip(edge_and_random_uints(31), encode_uint, decode_uint);
  RangeEncoder enc;
  UIntModel m;
  EXPECT_EQ(test::parameter_of([&] { encode_uint(enc, m, 0xFFFFFFFFu); }), "v");
}

TEST(CoreRangeCoder, SmallIntegersCostAboutTheirEntropy) {
  // Geometric values (P(v) = 2^-(v+1), entropy 2 bits) take about 2.3 adaptive bits each (prefix
  // and modelled suffix), at the 0.0115 bits of adaptation overhead of the skewed-source test:
  // 2.03 bits. Suffix bits coded as bypass would cost 0.07 bits more.
  std::mt19937_64 rng(37);
  std::geometric_distribution<std::uint32_t> geometric(0.5);
  RangeEncoder enc;
  UIntModel m;
  const int count = 100000;
  for (int i = 0; i < count; ++i) encode_uint(enc, m, geometric(rng));
  EXPECT_LT(double(enc.finish().size()) * 8.0 / count, 2.04);
}

TEST(CoreRangeCoder, NonzeroSignedIntegersRoundTrip) {
  std::vector<std::int32_t> values{1, -1, 2, -2, std::numeric_limits<std::int32_t>::max(),
                                   std::numeric_limits<std::int32_t>::min(), -std::numeric_limits<std::int32_t>::max()};
  for (std::uint32_t v : edge_and_random_uints(41))
    if (std::int32_t s = std::int32_t(v >> 1); s != 0) values.push_back((v & 1u) != 0 ? -s : s);
  expect_round_trip(values, encode_nonzero, decode_nonzero);
  RangeEncoder enc;
  UIntModel m;
  EXPECT_EQ(test::parameter_of([&] { encode_nonzero(enc, m, 0); }), "v");
}

TEST(CoreRangeCoder, APositiveMagnitudeOfTwoPow31IsRejected) {
  // |v| - 1 = 2^31 - 1 with a + sign has no int32; with a - sign it is INT32_MIN.
  for (std::uint32_t sign : {0u, 1u}) {
    RangeEncoder enc;
    UIntModel m;
    encode_uint(enc, m, 0x7FFFFFFFu);
    enc.encode_bypass(sign, 1);
    const std::vector<std::byte> stream = enc.finish();
    RangeDecoder dec(stream, "in.strata", "coefficients");
    UIntModel dm;
    if (sign == 0)
      EXPECT_EQ(error_of([&] { decode_nonzero(dec, dm); }), "in.strata: coefficients: signed integer out of range");
    else
      EXPECT_EQ(decode_nonzero(dec, dm), std::numeric_limits<std::int32_t>::min());
  }
}

TEST(CoreRangeCoder, SkewedSourceCostsItsEntropyPlusTheAdaptationOverhead) {
  // A model moving by a = 2^-5 of the way to each bit is an exponential moving average of the
  // source: in steady state its estimate has variance p(1-p) a / (2 - a), and coding with an
  // estimate off by e costs e^2 / (2 p (1-p) ln 2) bits more than coding with p. The overhead is
  // a / (2 (2 - a) ln 2) = 0.0115 bits a bit whatever p is. The sequence's own cost under p is
  // the reference (not n H(p), which sampling moves by ~0.001 bits a bit); 0.001 bits a bit of
  // slack covers the 12-bit probabilities, the truncated range and the rounded updates.
  const double a = 1.0 / 32, overhead = a / (2.0 * (2.0 - a) * std::log(2.0));
  for (double p1 : {0.05, 0.2}) {
    const std::vector<int> bits = bernoulli_bits(p1, 1000000, 43);
    double ideal = 0;
    for (int b : bits) ideal -= std::log2(b != 0 ? p1 : 1.0 - p1);
    const std::vector<std::byte> stream = encode_bits(bits);
    const double per_bit = (double(stream.size()) * 8.0 - ideal) / double(bits.size());
    EXPECT_LT(per_bit, overhead + 0.001) << "p1 = " << p1;
    EXPECT_GT(per_bit, overhead - 0.001) << "p1 = " << p1;  // a smaller one would mean a different model
    const double entropy = -(p1 * std::log2(p1) + (1 - p1) * std::log2(1 - p1));
    EXPECT_LT(double(stream.size()) * 8.0, 1.05 * entropy * double(bits.size())) << "p1 = " << p1;
    EXPECT_EQ(decode_bits(stream, bits.size()), bits);
  }
}

TEST(CoreRangeCoder, EmptyStreamIsEmptyAndTheEncoderIsReusable) {
  RangeEncoder enc;
  EXPECT_EQ(enc.bytes_so_far(), 0u);
  enc.encode_bypass(0, 0);  // zero bits code nothing
  EXPECT_TRUE(enc.finish().empty());
  const std::vector<std::byte> none;
  RangeDecoder dec(none, "in.strata", "coefficients");
  EXPECT_EQ(dec.decode_bypass(0), 0u);
  EXPECT_NO_THROW(dec.finish_check());

  // After finish() the encoder starts over: the same symbols give the same bytes.
  const std::vector<int> bits = bernoulli_bits(0.3, 5000, 47);
  const std::vector<std::byte> fresh = encode_bits(bits);
  BitModel m;
  for (int b : bits) enc.encode_bit(m, b);
  EXPECT_EQ(enc.bytes_so_far(), fresh.size());
  EXPECT_EQ(enc.finish(), fresh);
  EXPECT_EQ(enc.bytes_so_far(), 0u);
  EXPECT_TRUE(enc.finish().empty());
}

TEST(CoreRangeCoder, BytesSoFarIsTheSizeFinishWouldReturn) {
  const std::vector<int> bits = bernoulli_bits(0.1, 20000, 53);
  for (std::size_t stop : {std::size_t(1), std::size_t(7), std::size_t(100), std::size_t(4321), bits.size()}) {
    RangeEncoder enc;
    BitModel m;
    for (std::size_t i = 0; i < stop; ++i) enc.encode_bit(m, bits[i]);
    const std::size_t predicted = enc.bytes_so_far();
    EXPECT_EQ(enc.finish().size(), predicted) << stop << " bits";
  }
}

TEST(CoreRangeCoder, TruncatedStreamsAreReported) {
  // Uniform adaptive bits and integers: every symbol needs its share of the bytes, so every cut shows.
  const std::vector<std::uint32_t> values = edge_and_random_uints(59);
  const std::vector<int> bits = bernoulli_bits(0.5, 4000, 61);
  RangeEncoder enc;
  UIntModel em;
  BitModel eb;
  for (std::size_t i = 0; i < values.size(); ++i) {
    encode_uint(enc, em, values[i]);
    enc.encode_bit(eb, bits[i % bits.size()]);
  }
  const std::vector<std::byte> stream = enc.finish();
  for (std::size_t cut = 0; cut <= 32; ++cut) {
    const std::span<const std::byte> prefix(stream.data(), stream.size() - cut);
    RangeDecoder dec(prefix, "in.strata", "coefficients");
    UIntModel dm;
    BitModel db;
    const std::string error = error_of([&] {
      for (std::size_t i = 0; i < values.size(); ++i) {
        decode_uint(dec, dm);
        dec.decode_bit(db);
      }
      dec.finish_check();
    });
    EXPECT_EQ(error, cut == 0 ? "" : kTruncated) << "cut by " << cut;
  }
  // Bypass bits consume input at a fixed rate: one missing byte is always seen.
  RangeEncoder bypass;
  bypass.encode_bypass(0xDEADBEEF, 32);
  const std::vector<std::byte> raw = bypass.finish();
  ASSERT_EQ(raw.size(), 5u);  // 32 bits in four renormalization bytes, and the flush byte
  RangeDecoder short_by_one(std::span<const std::byte>(raw).first(4), "in.strata", "coefficients");
  short_by_one.decode_bypass(32);
  EXPECT_EQ(error_of([&] { short_by_one.finish_check(); }), kTruncated);
}

TEST(CoreRangeCoder, AnAllOnesPrefixIsRejected) {
  // 32 prefix ones would announce an integer of 33 bits.
  RangeEncoder enc;
  UIntModel em;
  for (BitModel& m : em.prefix) enc.encode_bit(m, 1);
  const std::vector<std::byte> stream = enc.finish();
  RangeDecoder dec(stream, "in.strata", "coefficients");
  UIntModel dm;
  EXPECT_EQ(error_of([&] { decode_uint(dec, dm); }), "in.strata: coefficients: integer code longer than 32 bits");
  // An all-0xFF input keeps the code above every bound, so it decodes as ones too.
  const std::vector<std::byte> ff(64, std::byte{0xFF});
  RangeDecoder garbage(ff, "in.strata", "coefficients");
  UIntModel gm;
  EXPECT_EQ(error_of([&] { decode_uint(garbage, gm); }), "in.strata: coefficients: integer code longer than 32 bits");
}

TEST(CoreRangeCoder, GarbageDecodesWithinItsSpanAndOnlyFormatErrors) {
  // Each random input is followed in memory by 16 guard bytes, once zeros and once 0xFF: the
  // decoded values and the error must not depend on them, so nothing past the span is read.
  std::mt19937_64 rng(67);
  // The values decoded and the message of the FormatError that ended the decoding, if any.
  const auto decode_all = [](std::span<const std::byte> bytes) {
    std::vector<std::int64_t> values;
    RangeDecoder dec(bytes, "in.strata", "coefficients");
    UIntModel m;
    const std::string error = error_of([&] {
      for (int i = 0; i < 64; ++i) {  // a bounded number of calls, each of them bounded
        values.push_back(decode_uint(dec, m));
        values.push_back(decode_nonzero(dec, m));
      }
      dec.finish_check();
    });
    return std::pair(values, error);
  };
  for (int trial = 0; trial < 2000; ++trial) {
    const std::size_t size = rng() % 48;
    std::vector<std::byte> zeros(size + 16, std::byte{0}), ones(size + 16, std::byte{0xFF});
    for (std::size_t i = 0; i < size; ++i) zeros[i] = ones[i] = std::byte(rng() & 0xFF);
    const auto [values, error] = decode_all(std::span<const std::byte>(zeros).first(size));
    EXPECT_EQ(decode_all(std::span<const std::byte>(ones).first(size)), std::pair(values, error)) << "trial " << trial;
    // Garbage may decode (into whatever integers) or fail, and a failure names the input.
    if (!error.empty()) {
      EXPECT_EQ(error.rfind("in.strata: coefficients: ", 0), 0u) << error;
    }
  }
}
