// Transfer-function culling of compressed bricks against a brute-force check. A sparse CT with
// thin bright wires on a zero background (a vascular stent) used to render black: the coarse
// bricks average the wires below the presets' opacity threshold and were culled by their own
// histograms, so the cut stopped at the root. Every brick whose decoded samples a preset makes
// visible must now be reached, for signed and unsigned sources and quantized or float storage.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <tuple>

#include "lod/lod_test_util.hpp"
#include "strata/lod/selection.hpp"
#include "strata/render/transfer_function.hpp"
#include "ta/ta_test_util.hpp"

namespace strata::render {
namespace {

using Key = std::tuple<int, int, int>;

// 48 x 48 x 96 voxels, 74 % zeros like the reported CT: a soft-tissue cylinder of 40..300 and
// six helical wires of 2000, two voxels thick; `signed_air` adds -1000 air pockets.
Volume stent(DType dtype, bool signed_air) {
  Volume v(Extent{48, 48, 96}, dtype);
  const auto set = [&](std::int64_t x, std::int64_t y, std::int64_t z, double value) {
    if (dtype == DType::i16) v.view<std::int16_t>()(x, y, z) = std::int16_t(value);
    else v.view<std::uint16_t>()(x, y, z) = std::uint16_t(value);
  };
  for (std::int64_t z = 0; z < 96; ++z)
    for (std::int64_t y = 0; y < 48; ++y)
      for (std::int64_t x = 0; x < 48; ++x) {
        const double r = std::hypot(double(x) - 24, double(y) - 24);
        if (r < 12) set(x, y, z, 40 + double((x * 7 + y * 13 + z * 29) % 260));
        if (signed_air && r > 19 && (z / 12) % 2 == 0) set(x, y, z, -1000);
      }
  for (int wire = 0; wire < 6; ++wire)
    for (int step = 0; step < 2000; ++step) {
      const double t = 96.0 * step / 2000, phase = wire * 3.14159265 / 3;
      const auto x = std::int64_t(std::lround(24 + 15 * std::cos(t / 6 + phase)));
      const auto y = std::int64_t(std::lround(24 + 15 * std::sin(t / 6 + phase)));
      const auto z = std::int64_t(t);
      for (int d = 0; d < 2; ++d) set(x + d, y, z, 2000), set(x, y + d, z, 2000);
    }
  return v;
}

// Level-0 bricks with a decoded sample where `tf` is opaque: what the culling must keep.
std::set<Key> visible_by_brute_force(const ta::TaVolume& t, const TransferFunction& tf) {
  const ValueMapping m = tf.mapping(t.value_min(), t.value_max());
  const Volume level0 = t.decode_box(0, Box::whole(t.geometry().level(0).dims), t.rank());
  const auto view = level0.view<float>();
  std::set<Key> keys;
  const Extent grid = t.geometry().level(0).bricks;
  for (std::int64_t bz = 0; bz < grid.z; ++bz)
    for (std::int64_t by = 0; by < grid.y; ++by)
      for (std::int64_t bx = 0; bx < grid.x; ++bx) {
        const Box core = t.geometry().brick_core_box(0, bx, by, bz);
        bool seen = false;
        for (std::int64_t z = core.lo.z; z < core.hi.z && !seen; ++z)
          for (std::int64_t y = core.lo.y; y < core.hi.y && !seen; ++y)
            for (std::int64_t x = core.lo.x; x < core.hi.x && !seen; ++x) {
              const double s = m.normalise(view(x, y, z));
              seen = tf.visible(s, s);
            }
        if (seen) keys.insert({int(bx), int(by), int(bz)});
      }
  return keys;
}

TEST(RenderTransferCulling, EveryBrickAPresetShowsIsReached) {
  test::TempDir dir;
  for (const auto& [dtype, signed_air] : {std::pair{DType::i16, false}, {DType::i16, true}, {DType::u16, false}})
    for (const char* quant : {"u16,b8log+", "f32"}) {
      const std::string label = std::string(dtype_name(dtype)) + (signed_air ? " with air" : "") + ", " + quant;
      const auto path = dir / "stent.strata";
      ta::testing::compress(stent(dtype, signed_air), path, ta::testing::params(16, 2, 8, quant));
      const ta::TaVolume t(path);
      const Vec3 c = lod::testing::centre_of(t);
      // A huge image: every brick must refine to level 0.
      const lod::View close = lod::testing::perspective_view(c + Vec3{0, 0, 300}, c, 1 << 20, 60);
      const lod::View far = lod::testing::perspective_view(c + Vec3{0, 0, 300}, c, 64, 60);
      lod::SelectionOptions unlimited;
      unlimited.max_bricks = 1 << 20;
      unlimited.memory_budget = std::uint64_t(1) << 40;
      for (std::string_view name : TransferFunction::preset_names()) {
        const TransferFunction tf = TransferFunction::preset(name);
        const std::uint64_t bins = tf.visible_bins(t.value_min(), t.value_max());
        const std::set<Key> want = visible_by_brute_force(t, tf);
        std::set<Key> got;
        for (const lod::CutBrick& b : lod::select_cut(t, close, bins, unlimited).bricks) {
          EXPECT_EQ(b.key.level, 0) << label << ", " << name;
          got.insert({b.key.x, b.key.y, b.key.z});
        }
        for (const Key& k : want)
          EXPECT_TRUE(got.count(k)) << label << ", " << name << ": brick " << std::get<0>(k) << "," << std::get<1>(k)
                                    << "," << std::get<2>(k) << " has visible samples but was culled";
        // From far away the cut stays coarse, yet never empty while something is visible.
        if (!want.empty()) {
          EXPECT_FALSE(lod::select_cut(t, far, bins, unlimited).bricks.empty()) << label << ", " << name;
        }
      }
    }
}

}  // namespace
}  // namespace strata::render
