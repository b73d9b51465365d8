// Paper 2's error-driven LOD (Alg. 2) on a ta-global file: one error target ε picks each
// brick's rank from the feature-scale table and bounds refinement by the minimum and maximum
// error fronts; a larger ε never selects more bricks, finer bricks or higher ranks.
#include <gtest/gtest.h>

#include <map>
#include <numeric>
#include <tuple>

#include "lod/lod_test_util.hpp"
#include "strata/core/error.hpp"
#include "strata/lod/brick_provider.hpp"
#include "strata/lod/selection.hpp"

using namespace strata;
using namespace strata::lod;
using namespace strata::lod::testing;

namespace {

// The prisms of Prisms64 coded by ta-global at rank 8 (ladder 2, 4, 6, 8).
using GlobalPrisms64 = PrismsVolume<&kGlobal>;

using KeyTuple = std::tuple<int, int, int, int>;
KeyTuple tuple_of(const store::BrickKey& k) { return {k.level, k.x, k.y, k.z}; }

bool is_ancestor_or_self(const store::BrickKey& a, const store::BrickKey& b) {
  if (a.level < b.level) return false;
  const int s = a.level - b.level;
  return (b.x >> s) == a.x && (b.y >> s) == a.y && (b.z >> s) == a.z;
}

Selection cut_at(const ta::TaVolume& t, const View& view, double feature_scale, double lod = 1.0) {
  SelectionOptions o;
  o.feature_scale = feature_scale;
  o.lod = lod;
  return select_cut(t, view, kAllBins, o);
}

double target_rmse(const ta::TaVolume& t, double feature_scale) { return feature_scale * (t.value_max() - t.value_min()); }

std::size_t ladder_index(const ta::TaVolume& t, int rank) {
  const auto& ladder = t.feature_scale_ladder();
  return std::size_t(std::find(ladder.begin(), ladder.end(), rank) - ladder.begin());
}

const std::vector<double> kTargets{0.0005, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.3, 1.0};

}  // namespace

// Every brick carries the lowest ladder rank whose stored error meets ε (or the full rank), and
// the cut obeys line 12: a brick above level 0 stays only when its lowest rank meets ε, or its
// full rank does and it is small on screen.
TEST(LodFeatureScale, RanksAndRefinementFollowTheTable) {
  const ta::TaVolume& t = GlobalPrisms64::volume();
  ASSERT_TRUE(t.global());
  const auto& ladder = t.feature_scale_ladder();
  ASSERT_EQ(ladder, (std::vector<int>{2, 4, 6, 8}));
  int coarse_kept = 0, low_ranks = 0;
  for (double distance : {120.0, 400.0, 3000.0})
    for (double eps : kTargets) {
      const Selection cut = cut_at(t, view_from(t, distance), eps);
      ASSERT_FALSE(cut.budget_hit());
      const double target = target_rmse(t, eps);
      std::int64_t counted = 0;
      for (const CutBrick& b : cut.bricks) {
        const auto errors = t.rank_errors(b.key);
        const std::size_t i = ladder_index(t, b.rank);
        ASSERT_LT(i, ladder.size()) << "rank " << b.rank << " is not on the ladder";
        EXPECT_TRUE(errors[i] <= target || i + 1 == ladder.size());
        if (i > 0) {
          EXPECT_GT(errors[i - 1], target) << "a lower rank meets the target";
        }
        if (b.key.level > 0) {
          EXPECT_TRUE(errors.front() <= target || (errors.back() <= target && b.pixels_per_voxel <= 1.0))
              << "eps " << eps << " kept brick level " << int(b.key.level) << " that line 12 refines";
          ++coarse_kept;
        }
        low_ranks += b.rank < ladder.back();
      }
      for (const auto& [rank, n] : cut.per_rank) counted += n;
      EXPECT_EQ(counted, std::int64_t(cut.bricks.size()));
    }
  // The targets span both fronts: coarse bricks are kept and lower ranks chosen somewhere.
  EXPECT_GT(coarse_kept, 0);
  EXPECT_GT(low_ranks, 0);
}

// Monotonicity (the acceptance): from a smaller ε to a larger one the cut only coarsens,
// has no more bricks, and a brick in both cuts never gets a higher rank.
TEST(LodFeatureScale, LargerTargetsNeverSelectMoreBricksOrHigherRanks) {
  const ta::TaVolume& t = GlobalPrisms64::volume();
  for (double distance : {120.0, 400.0, 3000.0}) {
    const View view = view_from(t, distance);
    std::vector<Selection> cuts;
    for (double eps : kTargets) cuts.push_back(cut_at(t, view, eps));
    EXPECT_GT(cuts.front().bricks.size(), cuts.back().bricks.size()) << "the targets should span several cuts";
    for (std::size_t i = 1; i < cuts.size(); ++i) {
      const Selection &fine = cuts[i - 1], &coarse = cuts[i];
      EXPECT_LE(coarse.bricks.size(), fine.bricks.size()) << "eps " << kTargets[i];
      EXPECT_LE(coarse.bytes, fine.bytes);
      std::map<KeyTuple, int> fine_rank;
      for (const CutBrick& b : fine.bricks) fine_rank[tuple_of(b.key)] = b.rank;
      for (const CutBrick& c : coarse.bricks) {
        if (auto it = fine_rank.find(tuple_of(c.key)); it != fine_rank.end()) {
          EXPECT_LE(c.rank, it->second);
        }
        // Every coarse-cut brick covers fine-cut bricks: it is never finer than what it replaces.
        for (const CutBrick& f : fine.bricks) {
          if (is_ancestor_or_self(f.key, c.key)) {
            EXPECT_EQ(tuple_of(f.key), tuple_of(c.key)) << "eps " << kTargets[i];
          }
        }
      }
    }
  }
}

// The fronts at the ends: a target every brick meets at its lowest rank keeps the root; one no
// coarse brick meets refines to level 0 even when the screen-space rule would stop early.
TEST(LodFeatureScale, TheFrontsOverrideTheScreenSpaceRule) {
  const ta::TaVolume& t = GlobalPrisms64::volume();
  const View far = view_from(t, 3000.0);
  const Selection screen = select_cut(t, far, kAllBins);
  ASSERT_EQ(screen.per_level[0], 0) << "far away the screen-space rule alone stays coarse";
  const Selection loose = cut_at(t, far, 1.0);
  ASSERT_EQ(loose.bricks.size(), 1u);
  EXPECT_EQ(loose.bricks[0].key.level, t.geometry().level_count() - 1);
  EXPECT_EQ(loose.bricks[0].rank, t.feature_scale_ladder().front());
  const Selection strict = cut_at(t, far, 1e-7);
  EXPECT_EQ(std::accumulate(strict.per_level.begin() + 1, strict.per_level.end(), std::int64_t(0)), 0)
      << "a target no coarse brick meets forces level 0";
}

// The provider reconstructs each brick at its chosen rank, capped by the frame's rank slider.
TEST(LodFeatureScale, TheProviderDecodesEachBrickAtItsRank) {
  const ta::TaVolume& t = GlobalPrisms64::volume();
  const Selection cut = cut_at(t, view_from(t, 400.0), 0.02);
  ASSERT_GT(cut.per_rank.size(), 1u) << "the test needs several ranks in one cut";
  BrickProvider provider(t);
  for (int slider : {8, 4}) {
    const FrameBricks frame = provider.acquire(cut, slider, true);
    ASSERT_EQ(frame.bricks.size(), cut.bricks.size());
    std::map<KeyTuple, int> chosen;
    for (const CutBrick& b : cut.bricks) chosen[tuple_of(b.key)] = b.rank;
    tensor::BrickReconstructor reconstructor;
    ta::DecodeScratch scratch;
    std::vector<float> expected(16 * 16 * 16);
    for (const ResidentBrick& r : frame.bricks) {
      const int want = std::min(chosen.at(tuple_of(r.key)), slider);
      EXPECT_EQ(r.rank, want);
      if (r.is_constant()) continue;
      t.decode_brick(r.key, want, expected, reconstructor, scratch);
      EXPECT_EQ(*r.samples, expected);
    }
  }
}

TEST(LodFeatureScale, BadTargetsAndFilesWithoutATableAreRefused) {
  const ta::TaVolume& bricked = Prisms64::volume();
  try {
    cut_at(bricked, view_from(bricked, 400.0), 0.01);
    FAIL() << "a ta-bricked file has no feature-scale table";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "feature_scale");
    EXPECT_NE(std::string(e.what()).find("ta-global"), std::string::npos) << e.what();
  }
  EXPECT_EQ(cut_at(bricked, view_from(bricked, 400.0), 0).per_rank.size(), 0u) << "0 is off";
  const ta::TaVolume& t = GlobalPrisms64::volume();
  for (double bad : {-0.1, 1.5, std::nan("")}) EXPECT_THROW(cut_at(t, view_from(t, 400.0), bad), Error) << bad;
}
