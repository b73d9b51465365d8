// store::zstd_decompress on damaged frames: a FormatError naming the file and field in Strata's
// words ("damaged zstd data: ..."), never zstd's own text ("Data corruption detected").
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::store {
namespace {

std::vector<std::byte> sample_frame() {
  std::vector<std::uint16_t> samples(4096);
  for (std::size_t i = 0; i < samples.size(); ++i) samples[i] = std::uint16_t((i * i) % 977 + (i / 7) % 13);
  return zstd_compress(std::as_bytes(std::span(samples)), 3);
}

std::string failure(const std::vector<std::byte>& frame) {
  std::vector<std::byte> out;
  try {
    zstd_decompress(frame, 1 << 20, out, "f.strata", "brick (0, 1, 2, 3)");
  } catch (const FormatError& e) {
    return e.what();
  }
  return "";
}

TEST(ZstdFrame, DamagedDataIsDescribedInStrataWords) {
  // The first block's type set to the reserved 3 (after a 7-byte frame header: single segment, a
  // 2-byte content size), zstd's "Data corruption detected"; and a frame cut short.
  std::vector<std::byte> reserved_block = sample_frame();
  ASSERT_EQ(reserved_block[4], std::byte(0x60));
  reserved_block[7] |= std::byte(0x06);
  std::vector<std::byte> truncated = sample_frame();
  truncated.resize(truncated.size() - 9);
  for (const auto& frame : {reserved_block, truncated}) {
    const std::string message = failure(frame);
    EXPECT_TRUE(message.starts_with("f.strata: brick (0, 1, 2, 3): damaged zstd data: expected ")) << message;
    for (const char* library : {"Data corruption detected", "Corrupted block detected", "Src size is incorrect",
                                "corrupt zstd data"})
      EXPECT_EQ(message.find(library), std::string::npos) << message;
  }
  std::vector<std::byte> out;
  zstd_decompress(sample_frame(), 1 << 20, out, "f.strata", "brick");
  EXPECT_EQ(out.size(), 8192u);
}

}  // namespace
}  // namespace strata::store
