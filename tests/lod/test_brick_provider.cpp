// The per-frame brick provider: exact and progressive frames, the rank slider reusing cached
// models, transparent transfer functions and the cache budget.
#include <gtest/gtest.h>

#include <set>
#include <tuple>

#include "lod/lod_test_util.hpp"
#include "strata/lod/brick_provider.hpp"

using namespace strata;
using namespace strata::lod;
using namespace strata::lod::testing;

namespace {

using KeyTuple = std::tuple<int, int, int, int>;
KeyTuple tuple_of(const store::BrickKey& k) { return {k.level, k.x, k.y, k.z}; }

std::vector<float> reference(const ta::TaVolume& t, const store::BrickKey& key, int k) {
  tensor::BrickReconstructor r;
  ta::DecodeScratch s;
  std::vector<float> out(16 * 16 * 16);
  t.decode_brick(key, k, out, r, s);
  return out;
}

std::uint64_t non_constant(const Selection& cut) {
  return std::uint64_t(std::count_if(cut.bricks.begin(), cut.bricks.end(), [](const CutBrick& b) {
    return b.entry->kind != store::PayloadKind::constant;
  }));
}

// The frame holds exactly the cut's bricks, at rank k, each equal to TaVolume::decode_brick.
void expect_exact_frame(const ta::TaVolume& t, const Selection& cut, const FrameBricks& f, int k) {
  ASSERT_EQ(f.bricks.size(), cut.bricks.size());
  std::set<KeyTuple> want, got;
  for (const CutBrick& b : cut.bricks) want.insert(tuple_of(b.key));
  for (const ResidentBrick& b : f.bricks) {
    got.insert(tuple_of(b.key));
    EXPECT_EQ(b.rank, k);
    ASSERT_FALSE(b.is_constant());
    EXPECT_EQ(*b.samples, reference(t, b.key, k)) << "brick level " << int(b.key.level) << " x " << b.key.x;
  }
  EXPECT_EQ(want, got);
}

bool is_ancestor_or_self(const store::BrickKey& a, const store::BrickKey& b) {
  if (a.level < b.level) return false;
  const int s = a.level - b.level;
  return (b.x >> s) == a.x && (b.y >> s) == a.y && (b.z >> s) == a.z;
}

}  // namespace

TEST(LodBrickProvider, ExactModeReturnsTheFullCut) {
  const ta::TaVolume& t = Prisms64::volume();
  const Selection cut = select_cut(t, view_from(t, 150), kAllBins);
  ASSERT_GT(cut.bricks.size(), 8u);
  BrickProvider p(t);
  const FrameBricks f = p.acquire(cut, t.rank(), true);
  expect_exact_frame(t, cut, f, t.rank());
  EXPECT_EQ(f.stats.selected, cut.bricks.size());
  EXPECT_EQ(f.stats.resident, cut.bricks.size());
  EXPECT_EQ(f.stats.cache_misses, cut.bricks.size());
  EXPECT_EQ(f.stats.cache_hits, 0u);
  EXPECT_GT(f.stats.bytes_read, 0u);
  EXPECT_GT(f.stats.decode_ms, 0.0);
  EXPECT_EQ(f.stats.pending, 0u);
  // The same frame again: all hits, nothing read or decoded.
  const FrameBricks again = p.acquire(cut, t.rank(), true);
  EXPECT_EQ(again.stats.cache_hits, cut.bricks.size());
  EXPECT_EQ(again.stats.bytes_read, 0u);
  EXPECT_EQ(again.stats.decode_ms, 0.0);
}

// Prefetching queues the cut on the loader without waiting; once it is idle the same cut is
// all hits, the reading counted in that frame's stats.
TEST(LodBrickProvider, PrefetchedBricksAreHitsOnceLoaded) {
  const ta::TaVolume& t = Prisms64::volume();
  const Selection cut = select_cut(t, view_from(t, 150), kAllBins);
  ASSERT_GT(non_constant(cut), 0u);
  BrickProvider p(t);
  p.prefetch(cut, t.rank());
  p.wait_idle();
  const FrameBricks f = p.acquire(cut, t.rank(), true);
  EXPECT_EQ(f.stats.cache_hits, cut.bricks.size());
  EXPECT_EQ(f.stats.cache_misses, 0u);
  EXPECT_GT(f.stats.bytes_read, 0u);
  expect_exact_frame(t, cut, f, t.rank());
  // Another rank is another brick: prefetching it misses nothing already cached at the first.
  p.prefetch(cut, 2);
  p.wait_idle();
  EXPECT_EQ(p.acquire(cut, 2, true).stats.cache_misses, 0u);
}

TEST(LodBrickProvider, RankChangeReusesCachedPayloads) {
  const ta::TaVolume& t = Prisms64::volume();
  const Selection cut = select_cut(t, view_from(t, 150), kAllBins);
  BrickProvider p(t);
  const FrameBricks full = p.acquire(cut, t.rank(), true);
  ASSERT_GT(full.stats.bytes_read, 0u);
  const FrameBricks low = p.acquire(cut, 2, true);
  EXPECT_EQ(low.stats.bytes_read, 0u);  // models came from the model cache
  EXPECT_EQ(low.stats.cache_misses, non_constant(cut));  // yet every brick was reconstructed
  EXPECT_GT(low.stats.decode_ms, 0.0);
  expect_exact_frame(t, cut, low, 2);
  std::size_t differing = 0;
  for (std::size_t i = 0; i < low.bricks.size(); ++i) differing += *low.bricks[i].samples != *full.bricks[i].samples;
  EXPECT_GT(differing, 0u);
  // Ranks above the stored rank clamp to it: the full-rank bricks are hits.
  EXPECT_EQ(p.acquire(cut, 100, true).stats.cache_hits, cut.bricks.size());
}

TEST(LodBrickProvider, ProgressiveModeStandsInAncestorsThenRefines) {
  const ta::TaVolume& t = Prisms64::volume();
  BrickProvider p(t);
  const Selection far = select_cut(t, view_from(t, 1000), kAllBins);
  const Selection near = select_cut(t, view_from(t, 40), kAllBins);
  ASSERT_GT(near.per_level[0], 0);
  ASSERT_EQ(near.per_level[0], std::int64_t(near.bricks.size()));  // near: all full resolution
  p.acquire(far, t.rank(), true);  // warm: only coarse bricks resident

  const FrameBricks first = p.acquire(near, t.rank(), false);
  EXPECT_EQ(first.stats.cache_misses, non_constant(near));
  // Pending: the misses plus their missing level-1 ancestors (27 at most).
  EXPECT_LE(first.stats.pending, first.stats.cache_misses + 27);
  EXPECT_LT(first.bricks.size(), near.bricks.size());
  // Stand-ins are coarse bricks from the warm-up, and every cut brick is covered by one.
  for (const ResidentBrick& b : first.bricks) EXPECT_GT(b.key.level, 0);
  for (const CutBrick& c : near.bricks) {
    const bool covered = std::any_of(first.bricks.begin(), first.bricks.end(),
                                     [&](const ResidentBrick& r) { return is_ancestor_or_self(r.key, c.key); });
    EXPECT_TRUE(covered) << "cut brick x " << c.key.x << " y " << c.key.y << " z " << c.key.z;
  }

  p.wait_idle();
  const FrameBricks second = p.acquire(near, t.rank(), false);
  EXPECT_EQ(second.stats.cache_hits, near.bricks.size());
  EXPECT_EQ(second.stats.cache_misses, 0u);
  EXPECT_EQ(second.stats.pending, 0u);
  expect_exact_frame(t, near, second, t.rank());
}

TEST(LodBrickProvider, ColdProgressiveFrameShowsTheTopLevelAndQueuesAncestorsCoarseFirst) {
  const ta::TaVolume& t = Prisms64::volume();
  BrickProvider p(t);
  const Selection near = select_cut(t, view_from(t, 40), kAllBins);
  ASSERT_GT(near.bricks.size(), 1u);
  const FrameBricks cold = p.acquire(near, 4, false);
  // Nothing was resident (and prisms has no constant bricks): the top-level brick, decoded at
  // once, stands in for every brick of the cut, so the first frame is not empty.
  const int top = t.geometry().level_count() - 1;
  ASSERT_EQ(cold.bricks.size(), 1u);
  EXPECT_EQ(cold.bricks[0].key, (store::BrickKey{std::uint8_t(top), 0, 0, 0}));
  EXPECT_EQ(cold.stats.resident, 1u);
  p.wait_idle();
  // The missing ancestors were loaded too, so the next view change has stand-ins.
  EXPECT_TRUE(p.cache().contains({std::uint8_t(top), 0, 0, 0}, 4));
  EXPECT_TRUE(p.cache().contains({1, 0, 0, 0}, 4));
}

TEST(LodBrickProvider, RankChangeShowsTheOldRankUntilTheNewOneArrives) {
  const ta::TaVolume& t = Prisms64::volume();
  BrickProvider p(t);
  const Selection cut = select_cut(t, view_from(t, 150), kAllBins);
  p.acquire(cut, t.rank(), true);
  const FrameBricks f = p.acquire(cut, 3, false);
  ASSERT_EQ(f.bricks.size(), cut.bricks.size());
  for (const ResidentBrick& b : f.bricks) EXPECT_EQ(b.rank, t.rank());
  p.wait_idle();
  for (const ResidentBrick& b : p.acquire(cut, 3, false).bricks) EXPECT_EQ(b.rank, 3);
}

TEST(LodBrickProvider, TransparentTransferFunctionDecodesNothing) {
  const ta::TaVolume& t = Prisms64::volume();
  BrickProvider p(t);
  const Selection cut = select_cut(t, view_from(t, 40), 0);
  for (bool exact : {false, true}) {
    const FrameBricks f = p.acquire(cut, t.rank(), exact);
    EXPECT_TRUE(f.bricks.empty());
    EXPECT_EQ(f.stats.selected, 0u);
    EXPECT_EQ(f.stats.cache_misses, 0u);
    EXPECT_EQ(f.stats.bytes_read, 0u);
    EXPECT_EQ(f.stats.decode_ms, 0.0);
  }
  p.wait_idle();
  EXPECT_EQ(p.cache().size(), 0u);
  EXPECT_EQ(p.models().size(), 0u);
}

TEST(LodBrickProvider, CacheBudgetIsNeverExceeded) {
  const ta::TaVolume& t = Prisms64::volume();
  ProviderOptions o;
  o.cache_bytes = 10 * 16 * 16 * 16 * sizeof(float);
  o.model_cache_bytes = 40'000;
  o.loader_threads = 2;
  BrickProvider p(t, o);
  for (double d : {40.0, 150.0, 1000.0, 60.0}) {
    const Selection cut = select_cut(t, view_from(t, d), kAllBins);
    const FrameBricks progressive = p.acquire(cut, 5, false);
    EXPECT_LE(p.cache().bytes(), o.cache_bytes);
    EXPECT_LE(p.models().bytes(), o.model_cache_bytes);
    // A cut larger than the cache still comes back whole in exact mode.
    const FrameBricks exact = p.acquire(cut, 5, true);
    ASSERT_EQ(exact.bricks.size(), cut.bricks.size());
    EXPECT_LE(p.cache().bytes(), o.cache_bytes);
    EXPECT_LE(p.models().bytes(), o.model_cache_bytes);
  }
  p.wait_idle();
  EXPECT_LE(p.cache().bytes(), o.cache_bytes);
}

TEST(LodBrickProvider, ConstantBricksNeedNoDecode) {
  test::TempDir dir;
  Volume v(Extent{30, 30, 30}, DType::f32);
  for (float& x : v.samples<float>()) x = 0.5f;
  ta::testing::compress(v, dir / "flat.strata", ta::testing::params(16, 2, 8, "u16,b8log+"));
  const ta::TaVolume t(dir / "flat.strata");
  const Selection cut = select_cut(t, view_from(t, 30), kAllBins);
  ASSERT_FALSE(cut.bricks.empty());
  BrickProvider p(t);
  const FrameBricks f = p.acquire(cut, 4, false);
  ASSERT_EQ(f.bricks.size(), cut.bricks.size());
  for (const ResidentBrick& b : f.bricks) {
    EXPECT_TRUE(b.is_constant());
    EXPECT_EQ(b.constant_value, 0.5f);
  }
  EXPECT_EQ(f.stats.cache_misses, 0u);
  EXPECT_EQ(f.stats.bytes_read, 0u);
  p.wait_idle();
  EXPECT_EQ(p.cache().size(), 0u);
}

TEST(LodBrickProvider, CorruptPayloadFailsTheFrame) {
  test::TempDir dir;
  const auto path = dir / "bad.strata";
  ta::testing::compress(ta::testing::prisms({40, 40, 40}, 3), path, ta::testing::params(16, 2, 8, "u16,b8log+"));
  std::uint64_t offset = 0;
  {
    const ta::TaVolume t(path);
    const Selection cut = select_cut(t, view_from(t, 1e4), kAllBins);  // the root alone
    ASSERT_EQ(cut.bricks.size(), 1u);
    ASSERT_GT(cut.bricks[0].entry->size, 0u);
    offset = cut.bricks[0].entry->offset + cut.bricks[0].entry->size / 2;
  }
  test::flip_byte(path, offset);
  const ta::TaVolume t(path);
  const Selection cut = select_cut(t, view_from(t, 1e4), kAllBins);
  BrickProvider exact(t);
  EXPECT_THROW(exact.acquire(cut, 8, true), Error);
  // A cold progressive frame decodes the top level at once (its stand-in), so it fails too.
  BrickProvider progressive(t);
  EXPECT_THROW(progressive.acquire(cut, 8, false), Error);
}
