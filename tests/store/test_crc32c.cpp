// CRC-32C at every instruction-set level it has a variant for (the SSE4.2 instruction) and at
// the generic level (slicing-by-8 tables): the standard check values and equal results.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "strata/store/crc32c.hpp"
#include "support/isa_test.hpp"

namespace strata::store {

class StoreCrc32cPerIsa : public test::IsaTest {};

TEST_P(StoreCrc32cPerIsa, KnownVectors) {
  const ScopedIsaLimit limit(isa());
  EXPECT_EQ(crc32c("123456789", 9), 0xE3069283u);  // the standard CRC-32C check value
  EXPECT_EQ(crc32c("", 0), 0u);
  const std::vector<unsigned char> zeros(32, 0), ones(32, 0xff);
  EXPECT_EQ(crc32c(zeros.data(), zeros.size()), 0x8A9136AAu);  // RFC 3720 B.4
  EXPECT_EQ(crc32c(ones.data(), ones.size()), 0x62A8AB43u);    // RFC 3720 B.4
}

TEST_P(StoreCrc32cPerIsa, IncrementalUseEqualsOneCall) {
  const ScopedIsaLimit limit(isa());
  std::mt19937 rng(20);
  std::vector<unsigned char> data(1000);
  for (auto& b : data) b = static_cast<unsigned char>(rng());
  EXPECT_EQ(crc32c(data.data() + 300, 700, crc32c(data.data(), 300)), crc32c(data.data(), 1000));
}

TEST_P(StoreCrc32cPerIsa, EqualsTheTablePathForEveryLengthAndAlignment) {
  std::mt19937 rng(21);
  std::vector<unsigned char> data(4133);
  for (auto& b : data) b = static_cast<unsigned char>(rng());
  for (std::size_t offset : {0u, 1u, 3u, 7u})
    for (std::size_t length : {0u, 1u, 7u, 8u, 9u, 63u, 64u, 65u, 4096u}) {
      std::uint32_t generic = 0, wide = 0;
      {
        const ScopedIsaLimit limit(Isa::generic);
        generic = crc32c(data.data() + offset, length, 0x1234567u);
      }
      {
        const ScopedIsaLimit limit(isa());
        wide = crc32c(data.data() + offset, length, 0x1234567u);
      }
      EXPECT_EQ(wide, generic) << "offset " << offset << " length " << length;
    }
}

STRATA_INSTANTIATE_PER_ISA(StoreCrc32cPerIsa, Isa::generic, Isa::sse42);

}  // namespace strata::store
