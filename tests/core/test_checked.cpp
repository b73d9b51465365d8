// Overflow-checked sizes: products of dims and sample sizes never wrap modulo 2^64.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <string>

#include "strata/core/checked.hpp"
#include "strata/core/extent.hpp"
#include "strata/core/volume.hpp"
#include "support/test_support.hpp"

using namespace strata;

namespace {
constexpr std::int64_t kTwo32 = std::int64_t(1) << 32;
constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
}  // namespace

TEST(CoreChecked, MultiplyAndAddReportOverflow) {
  EXPECT_EQ(checked_mul<std::uint64_t>(std::uint64_t(1) << 32, std::uint64_t(1) << 31), std::uint64_t(1) << 63);
  EXPECT_FALSE(checked_mul<std::uint64_t>(std::uint64_t(1) << 32, std::uint64_t(1) << 32));
  EXPECT_EQ(checked_mul<std::int64_t>(-3, 4), -12);
  EXPECT_FALSE(checked_mul<std::int64_t>(kMax, 2));
  EXPECT_EQ(checked_add<std::uint64_t>(1, 2), 3u);
  EXPECT_FALSE(checked_add<std::uint64_t>(std::numeric_limits<std::uint64_t>::max(), 1));
  EXPECT_EQ(checked_product<std::int64_t>({2, 3, 7}), 42);
  EXPECT_FALSE(checked_product<std::int64_t>({kTwo32, kTwo32, 1}));
  // 2^62 * 4 * 1 wraps to 0 unchecked.
  EXPECT_FALSE(checked_product<std::int64_t>({std::int64_t(1) << 62, 4, 1}));
  static_assert(checked_product<std::int64_t>({4, 4, 4}) == 64);
}

TEST(CoreChecked, ExtentVoxelCountThrowsInsteadOfWrapping) {
  EXPECT_EQ((Extent{4, 5, 6}.voxel_count()), 120);
  const Extent huge{kTwo32, kTwo32, std::int64_t(1) << 40};
  EXPECT_FALSE(huge.checked_voxel_count());
  const std::string message = test::error_of([&] { (void)huge.voxel_count(); });
  EXPECT_NE(message.find("4294967296x4294967296x1099511627776"), std::string::npos) << message;
  EXPECT_NE(message.find("overflows"), std::string::npos) << message;
  EXPECT_FALSE((Box{{0, 0, 0}, huge}.size().checked_voxel_count()));
}

TEST(CoreChecked, VolumeInfoSizesAreChecked) {
  const VolumeInfo fine{{100, 200, 300}, DType::u16, {}};
  EXPECT_EQ(fine.byte_size(), 100u * 200 * 300 * 2);
  EXPECT_EQ(fine.bytes_per_slice(), 100u * 200 * 2);
  // Voxel count fits, bytes do not: 2^62 voxels of 2 bytes.
  const VolumeInfo wide{{std::int64_t(1) << 62, 1, 1}, DType::u16, {}};
  EXPECT_TRUE(wide.dims.checked_voxel_count());
  EXPECT_FALSE(wide.checked_byte_size());
  EXPECT_FALSE(wide.checked_bytes_per_slice());
  EXPECT_NE(test::error_of([&] { (void)wide.byte_size(); }).find("u16"), std::string::npos);
  EXPECT_NE(test::error_of([&] { (void)wide.bytes_per_slice(); }).find("slice"), std::string::npos);
  // Negative dims have no byte size.
  EXPECT_FALSE((VolumeInfo{{-1, 2, 2}, DType::u8, {}}.checked_byte_size()));
}

TEST(CoreChecked, VolumeTooLargeForMemoryIsAStrataError) {
  // 2^60 bytes: no machine allocates this; the error says what was asked for.
  const std::string message = test::error_of([] { Volume v(Extent{1 << 20, 1 << 20, 1 << 20}, DType::u8); });
  EXPECT_NE(message.find("cannot allocate"), std::string::npos) << message;
  EXPECT_NE(message.find("1048576x1048576x1048576"), std::string::npos) << message;
  EXPECT_NE(test::error_of([] { Volume v(Extent{kTwo32, kTwo32, kTwo32}, DType::u8); }).find("overflows"),
            std::string::npos);
}
