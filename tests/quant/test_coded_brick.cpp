// The coded Tucker brick (quant/coded_brick.hpp): every field survives the round trip, the
// step and error-table codes round the way their contracts say, the block-DCT basis is
// orthonormal, and corrupt payloads are errors, never crashes.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "support/test_support.hpp"
#include "strata/core/error.hpp"
#include "strata/quant/coded_brick.hpp"

using namespace strata;
using namespace strata::quant;

namespace {

CodedBrick sample_brick(bool dct, bool corrections, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::geometric_distribution<int> magnitude(0.3);
  auto code = [&] { return (rng() & 1 ? 1 : -1) * magnitude(rng); };
  CodedBrick b;
  b.dims = {12, 12, 12};
  b.ranks = {5, 3, 4};
  b.offset = 17.25f;
  b.core_step = 0.75f;
  if (dct) {
    b.dct_block = 4;
    b.margin = 2;  // 8 fitted rows: two blocks of 4
  }
  for (int c = 0; c < 12; ++c) b.factor_step_codes.push_back(std::uint8_t(20 + c));
  for (int n = 0; n < 3; ++n)
    for (int c = 0; c < b.ranks[std::size_t(n)] * (dct ? 4 : 12); ++c) b.factor_codes.push_back(code());
  for (int i = 0; i < 5 * 3 * 4; ++i) b.core_codes.push_back(i == 0 ? 4000 : code());
  for (int k = 0; k < 5; ++k) b.error_table.push_back(std::uint8_t(90 - 3 * k));
  if (corrections) {
    b.correction_step = 0.5f;
    for (std::uint32_t i : {3u, 4u, 100u, 1727u}) {
      b.correction_index.push_back(i);
      b.correction_codes.push_back(int(i % 7) - 3 == 0 ? 5 : int(i % 7) - 3);
    }
  }
  return b;
}

TEST(QuantCodedBrick, EveryFieldRoundTrips) {
  for (bool dct : {false, true})
    for (bool corrections : {false, true}) {
      const CodedBrick b = sample_brick(dct, corrections, 5);
      const std::vector<std::byte> bytes = serialize(b);
      EXPECT_EQ(deserialize_coded(bytes, 12, "test"), b) << "dct " << dct << " corrections " << corrections;
      EXPECT_LT(coded_header_bytes(b), bytes.size());
    }
  CodedBrick offset_only;
  offset_only.dims = {8, 8, 8};
  offset_only.offset = -3.5f;
  EXPECT_EQ(deserialize_coded(serialize(offset_only), 8, "test"), offset_only);
}

// Layout 2 codes block-DCT cores with their own contexts; bricks of layout 1 (format 1.1) still
// read, and a layout byte changed between the two decodes to something else or fails.
TEST(QuantCodedBrick, LayoutOneStillReadsAndTheLayoutSelectsTheContexts) {
  const CodedBrick b = sample_brick(true, false, 8);
  const std::vector<std::byte> one = serialize(b, 1), two = serialize(b);
  EXPECT_EQ(std::to_integer<int>(two[0]), int(kCodedLayout));
  EXPECT_EQ(deserialize_coded(one, 12, "test"), b);
  EXPECT_EQ(deserialize_coded(two, 12, "test"), b);
  EXPECT_NE(one, two);
  std::vector<std::byte> relabelled = two;
  relabelled[0] = std::byte{1};
  bool same = false;
  try {
    same = deserialize_coded(relabelled, 12, "test") == b;
  } catch (const FormatError&) {
  }
  EXPECT_FALSE(same);
  relabelled[0] = std::byte{kCodedLayout + 1};
  EXPECT_THROW(deserialize_coded(relabelled, 12, "test"), FormatError);
  EXPECT_THROW(serialize(b, 0), ParameterError);
}

TEST(QuantCodedBrick, DequantizedValuesAreCodesTimesSteps) {
  const CodedBrick b = sample_brick(true, true, 7);
  DequantizedModel m;
  dequantize(b, m);
  EXPECT_EQ(m.core[1], float(b.core_codes[1]) * b.core_step);
  EXPECT_EQ(m.offset, b.offset);
  // Mode 1, column 0: rows 0-1 and 10-11 are coded, rows 2-9 are the DCT basis.
  EXPECT_EQ(m.factors[0][0], float(b.factor_codes[0]) * factor_step(b.factor_step_codes[0]));
  EXPECT_EQ(m.factors[0][11], float(b.factor_codes[3]) * factor_step(b.factor_step_codes[0]));
  EXPECT_EQ(m.factors[0][2], block_dct_entry(8, 4, 0, 0));
  ASSERT_EQ(m.correction_value.size(), 4u);
  EXPECT_EQ(m.correction_value[3], float(b.correction_codes[3]) * 0.5f);
}

TEST(QuantCodedBrick, BlockDctBasisIsOrthonormalAndFrequencyMajor) {
  for (auto [rows, block] : {std::pair{28, 7}, std::pair{8, 4}, std::pair{60, 6}}) {
    double worst = 0;
    for (int a = 0; a < rows; ++a)
      for (int c = 0; c < rows; ++c) {
        double dot = 0;
        for (int r = 0; r < rows; ++r) dot += double(block_dct_entry(rows, block, r, a)) * block_dct_entry(rows, block, r, c);
        worst = std::max(worst, std::abs(dot - (a == c ? 1.0 : 0.0)));
      }
    EXPECT_LT(worst, 1e-6) << rows << "/" << block;  // float rounding of each entry
    // The first `blocks` columns are the constant (DC) vector of each block.
    const int blocks = rows / block;
    for (int c = 0; c < blocks; ++c)
      for (int r = 0; r < rows; ++r)
        EXPECT_FLOAT_EQ(block_dct_entry(rows, block, r, c), r / block == c ? float(1 / std::sqrt(double(block))) : 0.0f);
  }
}

TEST(QuantCodedBrick, StepAndErrorCodesRoundTheSafeWay) {
  for (double wanted : {1.5, 1.0, 0.3, 1e-3, 1e-7}) {
    const std::uint8_t c = factor_step_code(wanted);
    EXPECT_LE(double(factor_step(c)), wanted);                          // never coarser than asked
    if (c > 0) {
      EXPECT_GT(double(factor_step(std::uint8_t(c - 1))), wanted);  // the coarsest that fits
    }
  }
  EXPECT_EQ(factor_step(16), 0.25f);
  for (double bound : {0.0, 1e-9, 0.01, 0.4, 3.0, 1e4}) {
    const std::uint8_t c = error_code(bound, 0.5f);
    EXPECT_GE(error_value(c, 0.5f), bound);  // an upper bound stays an upper bound
    if (c > 1) {
      EXPECT_LT(error_value(std::uint8_t(c - 1), 0.5f), bound);
    }
  }
  EXPECT_EQ(error_code(0.0, 1.0f), 0);
  EXPECT_TRUE(std::isinf(error_value(error_code(1e300, 1.0f), 1.0f)));
}

TEST(QuantCodedBrick, InconsistentBricksAreRejectedOnWrite) {
  CodedBrick b = sample_brick(false, true, 9);
  b.correction_index = {5, 5, 6, 7};
  EXPECT_THROW(serialize(b), Error);
  b = sample_brick(false, false, 9);
  b.core_codes.pop_back();
  EXPECT_THROW(serialize(b), Error);
  b = sample_brick(true, false, 9);
  b.dct_block = 5;  // does not tile 8 rows
  EXPECT_THROW(serialize(b), Error);
}

// A block-DCT basis has one column per fitted row (8 here: 12 less a margin of 2 each side); a
// rank beyond it would read past the basis (found by fuzz_masked): refused on write and read.
TEST(QuantCodedBrick, BlockDctRanksBeyondTheFittedRowsAreRefused) {
  CodedBrick b = sample_brick(true, false, 9);
  std::vector<std::byte> bytes = serialize(b);
  b.ranks[0] = 9;
  EXPECT_THROW(serialize(b), Error);
  // The ranks' u16 at bytes 8-9: R1 = 9 > 8, caught before the basis is touched.
  bytes[8] = std::byte{9};
  bytes[9] = std::byte{0};
  EXPECT_NE(test::error_of([&] { (void)deserialize_coded(bytes, 12, "test"); }).find("test: coded brick ranks: "),
            std::string::npos);
}

// A block-DCT brick without a model whose one block spans the fitted rows (found by fuzz_masked:
// the context tables were sized from rank - 1 = -1) round-trips as the offset alone.
TEST(QuantCodedBrick, BlockDctBrickWithoutAModelInOneBlockRoundTrips) {
  CodedBrick b;
  b.dims = {12, 12, 12};
  b.offset = 3.5f;
  b.core_step = 1.0f;
  b.dct_block = 8;
  b.margin = 2;
  const CodedBrick back = deserialize_coded(serialize(b), 12, "test");
  EXPECT_EQ(back, b);
}

// Truncations, flipped bytes and a wrong expected width are FormatErrors or decode to some
// brick; nothing reads outside the payload (run under a sanitizer to see it).
TEST(QuantCodedBrick, CorruptPayloadsAreFormatErrors) {
  const std::vector<std::byte> good = serialize(sample_brick(true, true, 3));
  EXPECT_THROW(deserialize_coded(good, 16, "test"), FormatError);
  for (std::size_t cut = 0; cut < good.size(); cut += 3) {
    const std::vector<std::byte> cut_bytes(good.begin(), good.begin() + std::ptrdiff_t(cut));
    EXPECT_THROW(deserialize_coded(cut_bytes, 12, "test"), FormatError) << "cut at " << cut;
  }
  std::mt19937 rng(17);
  int errors = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<std::byte> bad = good;
    bad[rng() % bad.size()] ^= std::byte(1 + rng() % 255);
    try {
      (void)deserialize_coded(bad, 12, "test");
    } catch (const FormatError& e) {
      EXPECT_NE(std::string(e.what()).find("test"), std::string::npos);
      ++errors;
    }
  }
  EXPECT_GT(errors, 0);
}

}  // namespace
