// The reconstructed-brick and model caches: LRU order, the byte budget, stand-in lookups and
// thread safety.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "strata/lod/brick_cache.hpp"
#include "strata/lod/model_cache.hpp"

using namespace strata;
using namespace strata::lod;

namespace {

BrickSamples samples(std::size_t floats, float value = 0) {
  return std::make_shared<const std::vector<float>>(floats, value);
}

store::BrickKey key(int x, int level = 0) { return {std::uint8_t(level), x, 0, 0}; }

}  // namespace

TEST(LodBrickCache, EvictsLeastRecentlyUsedWithinBudget) {
  BrickCache c(3 * 100 * sizeof(float));
  ASSERT_TRUE(c.insert(key(0), 4, samples(100, 0)));
  ASSERT_TRUE(c.insert(key(1), 4, samples(100, 1)));
  ASSERT_TRUE(c.insert(key(2), 4, samples(100, 2)));
  ASSERT_TRUE(c.find(key(0), 4));  // 0 becomes the most recent; 1 is now the oldest
  ASSERT_TRUE(c.insert(key(3), 4, samples(100, 3)));
  EXPECT_TRUE(c.contains(key(0), 4));
  EXPECT_FALSE(c.contains(key(1), 4));
  EXPECT_TRUE(c.contains(key(2), 4));
  EXPECT_TRUE(c.contains(key(3), 4));
  EXPECT_EQ(c.bytes(), 3 * 100 * sizeof(float));
  EXPECT_EQ(c.counters().evictions, 1u);
  // A larger brick evicts as many as it needs.
  ASSERT_TRUE(c.insert(key(4), 4, samples(250)));
  EXPECT_LE(c.bytes(), c.budget());
  EXPECT_EQ(c.size(), 1u);
}

TEST(LodBrickCache, OversizedBricksAreNotKept) {
  BrickCache c(1000);
  EXPECT_FALSE(c.insert(key(0), 1, samples(1000)));
  EXPECT_EQ(c.bytes(), 0u);
  EXPECT_EQ(c.size(), 0u);
  BrickCache none(0);
  EXPECT_FALSE(none.insert(key(0), 1, samples(1)));
  EXPECT_FALSE(none.find(key(0), 1));
}

TEST(LodBrickCache, RanksAreSeparateEntriesAndStandInsFindTheNearestRank) {
  BrickCache c(1 << 20);
  c.insert(key(0), 2, samples(10, 2));
  c.insert(key(0), 8, samples(10, 8));
  EXPECT_FALSE(c.find(key(0), 6));
  int rank = 0;
  BrickSamples s = c.find_any_rank(key(0), 6, &rank);
  ASSERT_TRUE(s);
  EXPECT_EQ(rank, 8);
  EXPECT_EQ((*s)[0], 8.0f);
  s = c.find_any_rank(key(0), 3, &rank);
  EXPECT_EQ(rank, 2);
  EXPECT_FALSE(c.find_any_rank(key(1), 3));
}

TEST(LodBrickCache, StandInIndexForgetsEvictedRanks) {
  BrickCache c(2 * 10 * sizeof(float));
  c.insert(key(0), 2, samples(10));
  c.insert(key(1), 2, samples(10));
  c.insert(key(2), 2, samples(10));  // evicts key 0
  EXPECT_FALSE(c.find_any_rank(key(0), 2));
  c.insert(key(1), 2, samples(100));  // replacing with an oversized brick drops it
  EXPECT_FALSE(c.find_any_rank(key(1), 2));
  EXPECT_TRUE(c.find_any_rank(key(2), 2));
}

TEST(LodBrickCache, ConcurrentUseNeverExceedsTheBudget) {
  const std::uint64_t budget = 20 * 64 * sizeof(float);
  BrickCache c(budget);
  std::atomic<bool> over{false}, done{false};
  std::thread watcher([&] {
    while (!done) over = over || c.bytes() > budget;
  });
  {
    std::vector<std::jthread> writers;
    for (int t = 0; t < 2; ++t)
      writers.emplace_back([&c, t] {
        for (int i = 0; i < 5000; ++i) {
          const int x = (i * 7 + t * 13) % 97;
          if (i % 3) c.insert(key(x, t), 1 + i % 4, samples(std::size_t(16 + (i % 5) * 16)));
          else c.find_any_rank(key(x, t), 2);
        }
      });
  }
  done = true;
  watcher.join();
  EXPECT_FALSE(over);
  EXPECT_LE(c.bytes(), budget);
}

TEST(LodModelCache, KeepsModelsWithinBudget) {
  auto model = [] {
    auto m = std::make_shared<quant::DequantizedModel>();
    m->core.assign(8, 1.0f);
    for (auto& f : m->factors) f.assign(8, 1.0f);
    return BrickModel(m);
  };
  EXPECT_EQ(model_bytes(*model()), 32u * sizeof(float));
  ModelCache c(3 * 32 * sizeof(float));
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(c.insert(key(i), model()));
    EXPECT_LE(c.bytes(), c.budget());
  }
  EXPECT_EQ(c.size(), 3u);
  EXPECT_FALSE(c.find(key(0)));
  EXPECT_TRUE(c.find(key(4)));
}
