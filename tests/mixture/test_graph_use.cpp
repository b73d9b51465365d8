// Topological levels, the load-balanced schedule, palette propagation and the mixture lookup
// with error propagation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/gen/generators.hpp"
#include "strata/mixture/factorize.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/palette.hpp"
#include "strata/mixture/schedule.hpp"

namespace strata::mixture {
namespace {


// A hand-made graph: sources 0..3; 4 = (0,1), 5 = (2,4), 6 = (3,5), 7 = (0,2), 8 = (1,3).
MixtureGraph hand_graph() {
  MixtureGraph g;
  g.num_sources = 4;
  g.codebook.bits = 2;
  g.codebook.value = {0.2, 0.4, 0.6, 0.8};
  g.codebook.sigma = {0.01, 0.02, 0.03, 0.04};
  g.codebook.uses = {1, 1, 1, 1};
  g.nodes = {{0, 1, 0}, {2, 4, 1}, {3, 5, 2}, {0, 2, 3}, {1, 3, 1}};
  return g;
}

TEST(MixtureSchedule, TopologicalLevelsAndDepth) {
  const MixtureGraph g = hand_graph();
  EXPECT_EQ(topological_levels(g), (std::vector<std::uint32_t>{0, 0, 0, 0, 1, 2, 3, 1, 1}));
  EXPECT_EQ(topological_depth(g), 3u);
  const Schedule u = make_schedule(g, false);
  EXPECT_EQ(u.depth, 3u);
  EXPECT_EQ(std::vector<std::uint32_t>(u.phase(1).begin(), u.phase(1).end()), (std::vector<std::uint32_t>{4, 7, 8}));
  EXPECT_EQ(std::vector<std::uint32_t>(u.phase(2).begin(), u.phase(2).end()), (std::vector<std::uint32_t>{5}));
  // Balanced: target ceil(5 / 3) = 2 per phase; sinks 7 and 8 (level 1) can wait.
  const Schedule b = make_schedule(g, true);
  EXPECT_EQ(std::vector<std::uint32_t>(b.phase(1).begin(), b.phase(1).end()), (std::vector<std::uint32_t>{4, 8}));
  EXPECT_EQ(std::vector<std::uint32_t>(b.phase(2).begin(), b.phase(2).end()), (std::vector<std::uint32_t>{5, 7}));
  EXPECT_EQ(std::vector<std::uint32_t>(b.phase(3).begin(), b.phase(3).end()), (std::vector<std::uint32_t>{6}));
}

void check_schedule(const MixtureGraph& g, const Schedule& s) {
  ASSERT_EQ(s.order.size(), g.nodes.size());
  std::vector<std::uint32_t> phase_of(g.node_count(), 0);
  std::vector<int> seen(g.node_count(), 0);
  for (std::uint32_t p = 1; p <= s.depth; ++p)
    for (std::uint32_t id : s.phase(p)) {
      ASSERT_FALSE(g.is_source(id));
      ASSERT_EQ(seen[id]++, 0);
      phase_of[id] = p;
    }
  for (std::uint32_t p = 1; p <= s.depth; ++p)
    for (std::uint32_t id : s.phase(p)) {
      const auto& n = g.node(id);
      ASSERT_LT(phase_of[n.a], p);  // sources have phase 0
      ASSERT_LT(phase_of[n.b], p);
    }
}

TEST(MixtureSchedule, BalancedPhasesRespectDependencies) {
  const Volume v = gen::generate(gen::Params{gen::Kind::voronoi, {40, 40, 40}, 2, 50, std::nullopt});
  const HistogramMipmap h = HistogramMipmap::from_labels(v);
  const Factorization f = factorize(h, {});
  const Schedule b = make_schedule(f.graph, true);
  const Schedule u = make_schedule(f.graph, false);
  check_schedule(f.graph, b);
  check_schedule(f.graph, u);
  EXPECT_EQ(b.depth, f.stats.depth);
  // Balancing lowers the largest phase.
  std::uint64_t max_b = 0, max_u = 0;
  for (std::uint32_t p = 1; p <= b.depth; ++p) {
    max_b = std::max<std::uint64_t>(max_b, b.phase(p).size());
    max_u = std::max<std::uint64_t>(max_u, u.phase(p).size());
  }
  EXPECT_LE(max_b, max_u);
}

TEST(MixturePalette, EqualsBruteForceMixing) {
  const Volume v = gen::generate(gen::Params{gen::Kind::fibres, {48, 40, 32}, 4, 80, std::nullopt});
  const HistogramMipmap h = HistogramMipmap::from_labels(v);
  const Factorization f = factorize(h, {});
  const Schedule s = make_schedule(f.graph);
  const int C = 4;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::vector<float> colours(std::size_t(h.num_sources()) * C);
  for (auto& c : colours) c = U(rng);
  const std::vector<float> palette = propagate_palette(f.graph, s, colours, C);
  ASSERT_EQ(palette.size(), f.graph.node_count() * C);
  const MixtureLookup lut = MixtureLookup::build(f.graph, s);
  const ErrorReport e = measure_error(h, f, lut);
  for (int l = 0; l < h.level_count(); ++l) {
    const auto& L = h.level(l);
    for (std::size_t i = 0; i < L.ids.size(); ++i) {
      const std::uint32_t node = f.levels[std::size_t(l)].ids[i];
      const SparseMixture rec = lut.mean(node);
      const SparseMixture exact = h.table().mixture(L.ids[i]);
      for (int c = 0; c < C; ++c) {
        double mixed_rec = 0.0, mixed_exact = 0.0;
        for (const auto& x : rec.entries()) mixed_rec += x.weight * colours[std::size_t(x.index) * C + c];
        for (const auto& x : exact.entries()) mixed_exact += x.weight * colours[std::size_t(x.index) * C + c];
        const float got = palette[std::size_t(node) * C + c];
        // Same mixture as the lookup, up to float rounding along the path.
        ASSERT_NEAR(got, mixed_rec, 2e-5) << "level " << l << " voxel " << i;
        // And within the measured l1 error of the exact per-voxel colour mix.
        ASSERT_NEAR(got, mixed_exact, e.max_l1 + 2e-5);
        if (l == 0) {
          ASSERT_EQ(got, colours[std::size_t(L.ids[i]) * C + c]);
        }
      }
    }
  }
  // Thread count does not change the result.
  set_thread_count(1);
  const std::vector<float> serial = propagate_palette(f.graph, s, colours, C);
  set_thread_count(0);
  EXPECT_EQ(serial, palette);
  EXPECT_THROW(propagate_palette(f.graph, s, std::vector<float>(3), C), Error);
}

TEST(MixtureLookup, ErrorPropagationOnAHandExample) {
  const MixtureGraph g = hand_graph();
  const Schedule s = make_schedule(g);
  // Node 4 = 0.8 e0 + 0.2 e1 (bin 0: w 0.2, dw 0.01). Node 5 = 0.6 e2 + 0.4 node4 (bin 1).
  {
    const MixtureLookup L = MixtureLookup::build(g, s, ErrorModel::eq18);
    const auto m4 = L.mean_weights(4);
    const auto d4 = L.sigma(4);
    ASSERT_EQ(L.index(4).size(), 2u);
    EXPECT_DOUBLE_EQ(m4[0], 0.8);
    EXPECT_DOUBLE_EQ(m4[1], 0.2);
    // Eq. 18 with da = db = 0: dmu = mu sqrt(2) dw / w.
    EXPECT_NEAR(d4[0], 0.8 * std::sqrt(2.0) * 0.01 / 0.2, 1e-15);
    EXPECT_NEAR(d4[1], 0.2 * std::sqrt(2.0) * 0.01 / 0.2, 1e-15);
    const auto i5 = L.index(5);
    const auto m5 = L.mean_weights(5);
    const auto d5 = L.sigma(5);
    ASSERT_EQ(i5.size(), 3u);  // {0, 1, 2}
    const double w = 0.4, dw = 0.02;
    EXPECT_NEAR(m5[0], w * 0.8, 1e-15);
    EXPECT_NEAR(m5[2], 1 - w, 1e-15);
    // Component 0 comes from b = node 4 only: mu^2 ((db/b)^2 + 2 (dw/w)^2).
    const double rb = d4[0] / 0.8;
    EXPECT_NEAR(d5[0], w * 0.8 * std::sqrt(rb * rb + 2 * (dw / w) * (dw / w)), 1e-15);
    EXPECT_NEAR(d5[2], (1 - w) * std::sqrt(2.0) * dw / w, 1e-15);
  }
  {
    const MixtureLookup L = MixtureLookup::build(g, s, ErrorModel::linear);
    // da = db = 0: dmu_i = |b_i - a_i| dw.
    EXPECT_NEAR(L.sigma(4)[0], 0.01, 1e-15);
    EXPECT_NEAR(L.sigma(4)[1], 0.01, 1e-15);
    // Node 5, component 0: a = e2 (0), b = node 4 (0.8 +- 0.01).
    const double w = 0.4, dw = 0.02;
    EXPECT_NEAR(L.sigma(5)[0], std::sqrt(w * w * 0.01 * 0.01 + 0.8 * 0.8 * dw * dw), 1e-15);
    EXPECT_NEAR(L.sigma(5)[2], dw, 1e-15);
  }
  // The expectation sums to 1 exactly as a convex combination (unbiased, §3.6).
  const MixtureLookup L = MixtureLookup::build(g, s);
  for (std::uint32_t n = 0; n < g.node_count(); ++n) EXPECT_NEAR(L.mean(n).total(), 1.0, 1e-15);
}

TEST(MixtureLookup, ReconstructAnyVoxel) {
  const Volume v = gen::generate(gen::Params{gen::Kind::voronoi, {20, 18, 14}, 6, 12, std::nullopt});
  const HistogramMipmap h = HistogramMipmap::from_labels(v);
  const Factorization f = factorize(h, {});
  const MixtureLookup lut = MixtureLookup::build(f.graph, make_schedule(f.graph));
  const ErrorReport e = measure_error(h, f, lut);
  EXPECT_EQ(e.level_max_l1.size(), std::size_t(h.level_count()));
  double worst = 0.0;
  for (int l = 0; l < h.level_count(); ++l) {
    const Extent d = h.level(l).dims;
    for (std::int64_t z = 0; z < d.z; ++z)
      for (std::int64_t y = 0; y < d.y; ++y)
        for (std::int64_t x = 0; x < d.x; ++x) {
          const double err = SparseMixture::l1_distance(reconstruct(f, lut, l, x, y, z), h.mixture(l, x, y, z));
          if (l == 0) {
            ASSERT_EQ(err, 0.0);
          }
          worst = std::max(worst, err);
        }
  }
  EXPECT_DOUBLE_EQ(worst, e.max_l1);
  EXPECT_GT(e.max_l1, 0.0);
  EXPECT_LT(e.max_l1, 0.01);
  EXPECT_THROW(reconstruct(f, lut, h.level_count(), 0, 0, 0), Error);
}

}  // namespace
}  // namespace strata::mixture
