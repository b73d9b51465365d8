// Constant bricks: no tensor, no payload bytes, one value in the index (min == max), decoded
// exactly. Empty background is common in real scans, so this path carries much of the saving.
#include <gtest/gtest.h>

#include "ta/ta_test_util.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;

namespace {

// 40^3 prisms with z >= 20 set to 0. Brick 16, overlap 2 (core 12): level-0 brick rows bz = 2
// and 3 sample z in [22, 38) and [34, 40) (clamped): all zero, 4x4 bricks each. Row bz = 1
// samples z in [10, 26): mixed. The noisy prisms half has no constant brick.
Volume half_zero() {
  Volume v = prisms({40, 40, 40}, 5);
  auto s = v.view<std::uint16_t>();
  for (std::int64_t z = 20; z < 40; ++z)
    for (std::int64_t y = 0; y < 40; ++y)
      for (std::int64_t x = 0; x < 40; ++x) s(x, y, z) = 0;
  return v;
}

std::vector<std::int64_t> constant_counts(const store::ContainerReader& c, int levels) {
  std::vector<std::int64_t> n(std::size_t(levels), 0);
  for (const auto& e : c.bricks())
    if (e.kind == store::PayloadKind::constant) ++n.at(e.key.level);
  return n;
}

}  // namespace

TEST(TaConstant, ZeroHalfGivesConstantBricksThatDecodeExactly) {
  test::TempDir dir;
  const Volume v = half_zero();
  const CompressReport report = compress(v, dir / "half.strata", params(16, 2, 8, "u16,b8log+"));
  TaVolume t(dir / "half.strata");
  const auto& c = t.container();

  const auto counts = constant_counts(c, t.geometry().level_count());
  EXPECT_EQ(counts[0], 32);
  ASSERT_EQ(report.levels.size(), counts.size());
  for (std::size_t l = 0; l < counts.size(); ++l) EXPECT_EQ(report.levels[l].constant, counts[l]) << "level " << l;

  for (const auto& e : c.bricks()) {
    if (e.key.level != 0) continue;
    const bool zero_row = e.key.z >= 2;
    EXPECT_EQ(e.kind == store::PayloadKind::constant, zero_row)
        << "brick " << e.key.x << "," << e.key.y << "," << e.key.z;
    if (e.kind == store::PayloadKind::constant) {
      EXPECT_EQ(e.size, 0u);
      EXPECT_EQ(e.min, 0.0f);
      EXPECT_EQ(e.max, 0.0f);
      EXPECT_EQ(e.histogram, 1ull);  // 0 is the volume minimum: bin 0 only
      EXPECT_TRUE(c.payload(e).empty());
    } else {
      EXPECT_GT(e.size, 0u);
    }
  }
  // Cores of rows 2 and 3 are z in [24, 40): exactly zero, at every rank.
  for (int k : {1, 8}) {
    const Volume zeros = t.decode_box(0, {{0, 0, 24}, {40, 40, 40}}, k);
    for (float f : zeros.samples<float>()) ASSERT_EQ(f, 0.0f) << "rank " << k;
  }
}

TEST(TaConstant, ConstantVolumeIsConstantAtEveryLevelAndTiny) {
  test::TempDir dir;
  Volume v({50, 30, 20}, DType::f32);
  for (float& f : v.samples<float>()) f = 7.25f;
  const CompressReport report = compress(v, dir / "c.strata", params(16, 2, 8, "u16,b8log+"));
  TaVolume t(dir / "c.strata");
  // 50x30x20 -> 25x15x10 -> 13x8x5 -> 7x4x3: 5x3x2 + 3x2x1 + 2x1x1 + 1 bricks, all constant
  // (parents of constant children are their exact average).
  ASSERT_EQ(t.geometry().level_count(), 4);
  const std::vector<std::int64_t> expected{30, 6, 2, 1};
  EXPECT_EQ(constant_counts(t.container(), 4), expected);
  for (int l = 0; l < 4; ++l) {
    EXPECT_EQ(report.levels[std::size_t(l)].bricks, expected[std::size_t(l)]);
    EXPECT_EQ(report.levels[std::size_t(l)].constant, expected[std::size_t(l)]);
    const Volume d = t.decode_box(l, Box::whole(t.geometry().level(l).dims), 8);
    for (float f : d.samples<float>()) ASSERT_EQ(f, 7.25f) << "level " << l;
  }
  EXPECT_EQ(report.core_bytes + report.factor_bytes + report.brick_header_bytes, 0u);
  // Header, metadata and a 64-byte index entry per brick: no payloads at all.
  EXPECT_LT(std::filesystem::file_size(dir / "c.strata"), 64u + 39u * 64u + 2048u);
  for (const auto& e : t.container().bricks()) {
    EXPECT_EQ(e.min, 7.25f);
    EXPECT_EQ(e.max, 7.25f);
    // A flat range (lo == hi) has all values in bin 0.
    EXPECT_EQ(e.histogram, 1ull);
  }
}
