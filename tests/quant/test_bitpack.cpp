#include <gtest/gtest.h>

#include <random>

#include "strata/core/error.hpp"
#include "strata/quant/bitpack.hpp"

namespace strata::quant {
namespace {

std::vector<std::uint32_t> random_codes(std::size_t count, int bits, unsigned seed) {
  std::mt19937_64 rng(seed);
  const std::uint64_t limit = bits == 32 ? (1ull << 32) : (1ull << bits);
  std::vector<std::uint32_t> codes(count);
  for (auto& c : codes) c = std::uint32_t(rng() % limit);
  return codes;
}

TEST(QuantBitPack, RoundTripsEveryWidth) {
  for (int bits = 1; bits <= 32; ++bits) {
    for (std::size_t count : {std::size_t(0), std::size_t(1), std::size_t(7), std::size_t(4096)}) {
      const auto codes = random_codes(count, bits, unsigned(bits * 100 + count));
      std::vector<std::byte> packed(packed_size(count, bits));
      pack_codes(codes, bits, packed);
      std::vector<std::uint32_t> back(count);
      unpack_codes(packed, bits, back);
      EXPECT_EQ(back, codes) << bits << " bits, " << count << " codes";
      for (std::size_t i = 0; i < count; i += 97) EXPECT_EQ(read_code(packed.data(), bits, i), codes[i]);
    }
  }
}

TEST(QuantBitPack, TwelveBitCodesPackTwoPerThreeBytes) {
  const std::vector<std::uint32_t> codes{0xABC, 0x123, 0xFFF};
  EXPECT_EQ(packed_size(codes.size(), 12), 5u);
  std::vector<std::byte> packed(5);
  pack_codes(codes, 12, packed);
  const std::vector<std::byte> expected{std::byte(0xBC), std::byte(0x3A), std::byte(0x12), std::byte(0xFF),
                                        std::byte(0x0F)};
  EXPECT_EQ(packed, expected);
}

TEST(QuantBitPack, SixteenBitCodesAreLittleEndian) {
  const std::vector<std::uint32_t> codes{0x1234};
  std::vector<std::byte> packed(2);
  pack_codes(codes, 16, packed);
  EXPECT_EQ(packed[0], std::byte(0x34));
  EXPECT_EQ(packed[1], std::byte(0x12));
}

TEST(QuantBitPack, RejectsOversizedCodesAndShortBuffers) {
  std::vector<std::byte> packed(16);
  const std::vector<std::uint32_t> too_big{256};
  EXPECT_THROW(pack_codes(too_big, 8, packed), Error);
  const std::vector<std::uint32_t> ok(11, 1);
  std::vector<std::byte> small(packed_size(ok.size(), 12) - 1);
  EXPECT_THROW(pack_codes(ok, 12, small), Error);
  std::vector<std::uint32_t> out(11);
  EXPECT_THROW(unpack_codes(small, 12, out), Error);
  EXPECT_THROW(pack_codes(ok, 0, packed), Error);
  EXPECT_THROW(unpack_codes(packed, 33, out), Error);
}

}  // namespace
}  // namespace strata::quant
