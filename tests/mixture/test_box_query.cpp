// Box histograms (paper §3.6): naive level-0 scan, footprint assembly and the hybrid, checked
// against brute-force level-0 counts on generated label volumes with odd dimensions.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/mixture/box_query.hpp"
#include "strata/mixture/factorize.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/schedule.hpp"

namespace strata::mixture {
namespace {

struct Encoded {
  Factorization f;
  Schedule schedule;
  MixtureLookup lookup;
  double max_l1 = 0.0;
  std::uint32_t num_sources = 0;
  LabelMap map;
  Volume labels;
};

Volume generate(gen::Kind kind, Extent dims, std::int64_t count, std::uint64_t seed) {
  gen::Params p;
  p.kind = kind;
  p.dims = dims;
  p.seed = seed;
  p.count = count;
  return gen::generate(p);
}

Encoded encode_volume(Volume labels, int bits = 9) {
  Encoded e;
  e.labels = std::move(labels);
  HistogramMipmap h = HistogramMipmap::from_labels(e.labels, &e.map);
  FactorOptions o;
  o.bits = bits;
  e.f = factorize(h, o);
  e.schedule = make_schedule(e.f.graph);
  e.lookup = MixtureLookup::build(e.f.graph, e.schedule);
  e.max_l1 = measure_error(h, e.f, e.lookup).max_l1;
  e.num_sources = h.num_sources();
  return e;
}

Encoded encode(gen::Kind kind, Extent dims, std::int64_t count, std::uint64_t seed, int bits = 9) {
  return encode_volume(generate(kind, dims, count, seed), bits);
}

// fibres 64 x 64 x 32 with 200 ids (seed 11), shared by the tests that use it (built once).
const Encoded& fibres_64x64x32() {
  static const Encoded e = encode(gen::Kind::fibres, {64, 64, 32}, 200, 11);
  return e;
}

std::map<std::uint32_t, std::uint64_t> brute(const Factorization& f, const Box& b) {
  std::map<std::uint32_t, std::uint64_t> out;
  const MipLevel& l0 = f.levels[0];
  for (std::int64_t z = b.lo.z; z < b.hi.z; ++z)
    for (std::int64_t y = b.lo.y; y < b.hi.y; ++y)
      for (std::int64_t x = b.lo.x; x < b.hi.x; ++x) ++out[l0.ids[l0.index(x, y, z)]];
  return out;
}

struct Check {
  double l1 = 0.0;          // sum over labels of |count - true|
  std::size_t labels = 0;   // labels in the union
  std::size_t within_3sigma = 0;
};

Check compare(const BoxHistogram& r, const std::map<std::uint32_t, std::uint64_t>& truth) {
  Check c;
  std::map<std::uint32_t, std::pair<double, double>> got;
  for (const auto& e : r.counts) got[e.source] = {e.count, e.sigma};
  std::map<std::uint32_t, bool> all;
  for (auto& [s, _] : truth) all[s] = true;
  for (auto& [s, _] : got) all[s] = true;
  for (auto& [s, _] : all) {
    const double t = truth.count(s) ? double(truth.at(s)) : 0.0;
    const auto g = got.count(s) ? got.at(s) : std::pair<double, double>{0.0, 0.0};
    const double err = std::abs(g.first - t);
    c.l1 += err;
    ++c.labels;
    if (err <= 3.0 * g.second + 1e-9 * double(r.box.voxel_count()) + 1e-9) ++c.within_3sigma;
  }
  return c;
}

Box random_box(std::mt19937_64& rng, Extent d) {
  auto axis = [&](std::int64_t n, std::int64_t& lo, std::int64_t& hi) {
    std::uniform_int_distribution<std::int64_t> u(0, n);
    do {
      lo = u(rng);
      hi = u(rng);
      if (lo > hi) std::swap(lo, hi);
    } while (lo == hi);
  };
  Box b;
  axis(d.x, b.lo.x, b.hi.x);
  axis(d.y, b.lo.y, b.hi.y);
  axis(d.z, b.lo.z, b.hi.z);
  return b;
}

TEST(MixtureAlignedPieces, GreedyAlignedAndBorderOverhang) {
  using P = std::vector<std::pair<std::int64_t, int>>;
  EXPECT_EQ(aligned_pieces(3, 13, 64, 6), (P{{3, 0}, {4, 2}, {8, 2}, {12, 0}}));
  EXPECT_EQ(aligned_pieces(0, 64, 64, 6), (P{{0, 6}}));
  EXPECT_EQ(aligned_pieces(5, 6, 64, 6), (P{{5, 0}}));
  // dim 100 (levels 0..7): [96, 100) has real length 4 = a power of two, so the level-5 voxel
  // at 96 (support 4, a single chain of children) covers it; [0, 100) as one level-7 sample
  // would not be exact (its children have supports 64 and 36, averaged 1:1 by Eq. 4).
  EXPECT_EQ(aligned_pieces(0, 100, 100, 7), (P{{0, 6}, {64, 5}, {96, 5}}));
  EXPECT_EQ(aligned_pieces(64, 100, 100, 7), (P{{64, 5}, {96, 5}}));
  // dim 99: the rest after 96 is 3 (not a power of two): a 2-piece, then the level-1 voxel at
  // 98 whose real support is 1.
  EXPECT_EQ(aligned_pieces(90, 99, 99, 7), (P{{90, 1}, {92, 2}, {96, 1}, {98, 1}}));
  // dim 5 (levels 0..3): [4, 5) rest 1 -> the level-3 voxel? 4 is not a multiple of 8; level 2 at 4.
  EXPECT_EQ(aligned_pieces(0, 5, 5, 3), (P{{0, 2}, {4, 2}}));
  EXPECT_THROW(aligned_pieces(3, 3, 10, 4), Error);
  EXPECT_THROW(aligned_pieces(0, 11, 10, 4), Error);
}

class MixtureBoxQuery : public ::testing::TestWithParam<gen::Kind> {};

TEST_P(MixtureBoxQuery, RandomBoxesMatchBruteForce) {
  const Extent dims{45, 38, 29};  // odd sizes: borders at every level
  const Encoded e = encode(GetParam(), dims, GetParam() == gen::Kind::fibres ? 300 : 40, 7);
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  std::mt19937_64 rng(12345);
  std::vector<Box> boxes;
  for (int i = 0; i < 60; ++i) boxes.push_back(random_box(rng, dims));
  boxes.push_back(Box::whole(dims));
  boxes.push_back({{44, 37, 28}, {45, 38, 29}});  // 1-voxel box at the far corner
  boxes.push_back({{0, 0, 0}, {1, 1, 1}});
  boxes.push_back({{13, 0, 5}, {45, 38, 29}});    // touches the odd far borders
  boxes.push_back({{32, 32, 16}, {45, 38, 29}});
  std::size_t labels = 0, within = 0;
  for (const Box& b : boxes) {
    SCOPED_TRACE(b.to_string());
    const auto truth = brute(e.f, b);
    const double vol = double(b.voxel_count());
    // Naive: exact, sigma 0 (single-label input: level-0 node ids are the source ids).
    for (int threads : {1, 2}) {
      const BoxHistogram n = q.naive(b, threads);
      ASSERT_EQ(n.counts.size(), truth.size());
      // One entry per source, ascending (the per-thread parts merge in order).
      EXPECT_EQ(std::adjacent_find(n.counts.begin(), n.counts.end(),
                                   [](const BoxCount& a, const BoxCount& c) { return a.source >= c.source; }),
                n.counts.end());
      for (const auto& c : n.counts) {
        EXPECT_EQ(c.count, double(truth.at(c.source)));
        EXPECT_EQ(c.sigma, 0.0);
      }
      EXPECT_EQ(n.fetches, std::uint64_t(vol));
    }
    for (QueryMethod m : {QueryMethod::footprint, QueryMethod::hybrid}) {
      SCOPED_TRACE(std::string(query_method_name(m)));
      const BoxHistogram r = q.run(b, {m});
      EXPECT_NEAR(r.total(), vol, 1e-9 * vol);
      const Check c = compare(r, truth);
      // Quantisation bound: every sample's mixture is within max_l1 of the exact one.
      EXPECT_LE(c.l1, vol * e.max_l1 + 1e-9 * vol);
      labels += c.labels;
      within += c.within_3sigma;
      EXPECT_LE(r.fetches, std::uint64_t(vol));
      EXPECT_EQ(r.fetches, r.level0_voxels + r.samples);
      for (const auto& x : r.counts) EXPECT_GT(x.count, 0.0);
    }
  }
  // The propagated sigma is an estimate (independent samples): most labels fall within 3 sigma.
  EXPECT_GE(double(within), 0.9 * double(labels)) << within << " of " << labels;
  std::printf("[ info ] %s: %zu of %zu label counts within 3 sigma\n", std::string(gen::kind_name(GetParam())).c_str(),
              within, labels);
}

INSTANTIATE_TEST_SUITE_P(Kinds, MixtureBoxQuery, ::testing::Values(gen::Kind::voronoi, gen::Kind::fibres),
                         [](const auto& info) { return std::string(gen::kind_name(info.param)); });

TEST(MixtureBoxQuery, PlanTilesTheBoxExactly) {
  const Extent dims{45, 38, 29};
  const Encoded e = encode(gen::Kind::voronoi, dims, 20, 3);
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  std::mt19937_64 rng(99);
  for (int i = 0; i < 40; ++i) {
    const Box b = i == 0 ? Box::whole(dims) : random_box(rng, dims);
    for (QueryMethod m : {QueryMethod::footprint, QueryMethod::hybrid}) {
      std::vector<int> cover(std::size_t(dims.voxel_count()), 0);
      for (const FootprintBox& f : q.plan(b, {m})) {
        ASSERT_TRUE(b.contains(f.covered));
        const Extent ld = grid.level_dims(f.level);
        ASSERT_TRUE(Box::whole(ld).contains(f.cells));
        for (std::int64_t z = f.covered.lo.z; z < f.covered.hi.z; ++z)
          for (std::int64_t y = f.covered.lo.y; y < f.covered.hi.y; ++y)
            for (std::int64_t x = f.covered.lo.x; x < f.covered.hi.x; ++x) ++cover[std::size_t((z * dims.y + y) * dims.x + x)];
      }
      for (std::int64_t z = 0; z < dims.z; ++z)
        for (std::int64_t y = 0; y < dims.y; ++y)
          for (std::int64_t x = 0; x < dims.x; ++x) {
            const bool inside = x >= b.lo.x && x < b.hi.x && y >= b.lo.y && y < b.hi.y && z >= b.lo.z && z < b.hi.z;
            ASSERT_EQ(cover[std::size_t((z * dims.y + y) * dims.x + x)], inside ? 1 : 0);
          }
    }
  }
}

// Border voxels of coarse levels cover fewer than 2^l voxels per axis: a sample there must be
// weighted by its real support. dims 100 x 20 x 12: x = [0,64) + [64,96) + [96,100) where the
// last piece is one level-5 voxel covering 4 voxels (nominal 32); a weight of 32 per axis would
// break the total, and a wrong support would bias the counts.
TEST(MixtureBoxQuery, BorderSupportWeights) {
  const Extent dims{100, 20, 12};
  const Encoded e = encode(gen::Kind::voronoi, dims, 12, 5, 16);  // 16 bits: near-exact weights
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  const Box b{{64, 16, 8}, {100, 20, 12}};
  const auto plan = q.plan(b, {QueryMethod::footprint});
  bool clipped = false;
  for (const auto& f : plan)
    if (f.level > 0 && (f.cells.hi.x << f.level) > f.covered.hi.x) clipped = true;
  EXPECT_TRUE(clipped) << "expected a sample clipped at the x border";
  for (const Box& box : {b, Box::whole(dims), Box{{96, 0, 0}, {100, 20, 12}}}) {
    SCOPED_TRACE(box.to_string());
    const BoxHistogram r = q.footprint(box);
    const double vol = double(box.voxel_count());
    EXPECT_NEAR(r.total(), vol, 1e-9 * vol);
    const auto truth = brute(e.f, box);
    const Check c = compare(r, truth);
    EXPECT_LE(c.l1, vol * e.max_l1 + 1e-9 * vol);
    EXPECT_LT(c.l1, 1e-2 * vol);  // 16-bit weights: essentially exact
  }
}

TEST(MixtureBoxQuery, WholeVolumeIsFewSamplesAndOneVoxelIsExact) {
  const Extent dims{64, 64, 32};
  const Encoded& e = fibres_64x64x32();
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  const BoxHistogram w = q.hybrid(Box::whole(dims));
  EXPECT_EQ(w.fetches, 1u);  // the top voxel: z support 32 of 64, one chain of children
  EXPECT_NEAR(w.total(), double(dims.voxel_count()), 1e-6);
  const Box one{{17, 33, 9}, {18, 34, 10}};
  for (QueryMethod m : {QueryMethod::naive, QueryMethod::footprint, QueryMethod::hybrid}) {
    const BoxHistogram r = q.run(one, {m});
    ASSERT_EQ(r.counts.size(), 1u);
    EXPECT_EQ(r.counts[0].source, e.f.levels[0].ids[e.f.levels[0].index(17, 33, 9)]);
    EXPECT_EQ(r.counts[0].count, 1.0);
    EXPECT_EQ(r.counts[0].sigma, 0.0);
    EXPECT_EQ(r.fetches, 1u);
  }
}

TEST(MixtureBoxQuery, HybridReadsFewerIdsThanTheVolume) {
  const Extent dims{96, 96, 96};
  const Encoded e = encode(gen::Kind::fibres, dims, 300, 2);
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  const Box b{{5, 9, 3}, {69, 73, 67}};  // 64^3, unaligned
  const BoxHistogram f = q.footprint(b), h = q.hybrid(b);
  EXPECT_LT(f.fetches, std::uint64_t(b.voxel_count()) / 5);
  EXPECT_LT(h.fetches, std::uint64_t(b.voxel_count()) / 5);
  EXPECT_GE(h.level0_voxels, f.level0_voxels);
  // Expensive samples: thicker shell boxes move to level 0.
  QueryOptions costly;
  costly.sample_cost = 100.0;
  const BoxHistogram c = q.run(b, costly);
  EXPECT_LT(c.samples, f.samples);
  EXPECT_GT(c.level0_voxels, f.level0_voxels);
  for (const BoxHistogram* r : {&h, &c}) {
    EXPECT_NEAR(r->total(), double(b.voxel_count()), 1e-6);
    EXPECT_LE(compare(*r, brute(e.f, b)).l1, double(b.voxel_count()) * e.max_l1);
  }
  // A small box is cheaper to scan whole: one level-0 piece, exact.
  const Box small{{5, 9, 3}, {13, 17, 11}};
  const BoxHistogram s = q.hybrid(small);
  EXPECT_EQ(s.pieces, 1u);
  EXPECT_EQ(s.level0_voxels, 512u);
  EXPECT_EQ(compare(s, brute(e.f, small)).l1, 0.0);
}

// A grid whose reads fail on demand (a damaged file): the query throws, and the next query on
// the same thread starts from clean accumulators.
class FailingGrid final : public NodeGrid {
 public:
  explicit FailingGrid(const NodeGrid& g) : g_(g) {}
  int level_count() const override { return g_.level_count(); }
  Extent level_dims(int level) const override { return g_.level_dims(level); }
  std::uint32_t node_at(int level, std::int64_t x, std::int64_t y, std::int64_t z) const override {
    if (fail && z >= 10) throw Error("damaged");
    return g_.node_at(level, x, y, z);
  }
  void decode_box(int level, const Box& box, std::span<std::uint32_t> out) const override {
    if (fail && (box.hi.z << level) > 10) throw Error("damaged");
    g_.decode_box(level, box, out);
  }
  bool fail = false;

 private:
  const NodeGrid& g_;
};

TEST(MixtureBoxQuery, FailedReadsPropagateAndLeaveNoState) {
  const Extent dims{40, 36, 30};
  const Encoded e = encode(gen::Kind::voronoi, dims, 20, 4);
  FactorizationGrid inner(e.f);
  FailingGrid grid(inner);
  BoxQuery q(grid, e.lookup, e.num_sources);
  const Box b{{1, 2, 3}, {39, 35, 29}};
  const auto truth = brute(e.f, b);
  grid.fail = true;
  EXPECT_THROW(q.hybrid(b), Error);
  EXPECT_THROW(q.footprint(b), Error);
  EXPECT_THROW(q.naive(b, 2), Error);
  EXPECT_THROW(q.naive(b, 1), Error);
  grid.fail = false;
  for (QueryMethod m : {QueryMethod::naive, QueryMethod::hybrid, QueryMethod::footprint}) {
    QueryOptions o;
    o.method = m;
    o.threads = 2;
    const BoxHistogram r = q.run(b, o);
    EXPECT_NEAR(r.total(), double(b.voxel_count()), 1e-6);
    EXPECT_LE(compare(r, truth).l1, double(b.voxel_count()) * e.max_l1 + 1e-9);
  }
}

// The coarse method samples one level whose cells meeting the box fit the budget: its counts
// sum to the box volume for any box, and a budget that holds the whole box is an exact scan.
TEST(MixtureBoxQuery, CoarseRespectsTheBudgetAndSumsToTheBoxVolume) {
  const Extent dims{64, 64, 32};
  const Encoded& e = fibres_64x64x32();
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  std::mt19937_64 rng(5);
  for (int i = 0; i < 20; ++i) {
    const Box b = random_box(rng, dims);
    int previous = 99;
    for (std::uint64_t budget : {1, 8, 64, 512}) {
      const BoxHistogram r = q.coarse(b, budget);
      EXPECT_LE(r.fetches, std::max<std::uint64_t>(budget, r.level0_voxels)) << b.to_string();
      EXPECT_NEAR(r.total(), double(b.voxel_count()), 1e-9 * double(b.voxel_count())) << b.to_string();
      const int level = q.coarse_level(b, budget);
      EXPECT_LE(level, previous) << "a larger budget never samples a coarser level";
      previous = level;
    }
    const BoxHistogram exact = q.coarse(b, std::uint64_t(b.voxel_count()));
    const Check c = compare(exact, brute(e.f, b));
    EXPECT_EQ(c.l1, 0.0) << b.to_string();
  }
  EXPECT_THROW(q.coarse(Box::whole(dims), 0), Error);
}

// A box made of whole level-4 cells has no partly covered cell: the coarse answer is the
// footprint assembly's (the same 8 samples), with no placement term in sigma.
TEST(MixtureBoxQuery, CoarseOnAlignedCellsEqualsTheFootprint) {
  const Encoded& e = fibres_64x64x32();
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  const Box b{{16, 16, 0}, {48, 48, 32}};
  const BoxHistogram c = q.coarse(b, 8), f = q.footprint(b);
  EXPECT_EQ(q.coarse_level(b, 8), 4);
  EXPECT_EQ(c.samples, 8u);
  ASSERT_EQ(c.counts.size(), f.counts.size());
  for (std::size_t i = 0; i < c.counts.size(); ++i) {
    EXPECT_EQ(c.counts[i].source, f.counts[i].source);
    EXPECT_NEAR(c.counts[i].count, f.counts[i].count, 1e-9 * double(b.voxel_count()));
    EXPECT_NEAR(c.counts[i].sigma, f.counts[i].sigma, 1e-9 * double(b.voxel_count()));
  }
}

// The placement term spans every count a partly covered cell can give (a uniform law over the
// feasible range): on randomly placed labels (i.i.d. voxels), whose true spread is far
// narrower (hypergeometric), every label must fall within 3 sigma; dropping the term leaves
// most outside (12 of 160 were inside when it was tried).
TEST(MixtureBoxQuery, CoarseSigmaCoversRandomlyPlacedLabels) {
  const Extent dims{48, 40, 36};
  Volume labels(dims, DType::u8);
  std::mt19937_64 rng(17);
  for (auto& v : labels.samples<std::uint8_t>()) v = std::uint8_t(rng() % 4);
  const Encoded e = encode_volume(std::move(labels));
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  std::size_t labels_seen = 0, covered = 0;
  for (int i = 0; i < 40; ++i) {
    const Box b = random_box(rng, dims);
    const BoxHistogram r = q.coarse(b, 64);
    const Check c = compare(r, brute(e.f, b));
    labels_seen += c.labels;
    covered += c.within_3sigma;
  }
  EXPECT_EQ(covered, labels_seen);
}

TEST(MixtureBoxQuery, RejectsBadBoxesAndMethods) {
  const Encoded e = encode(gen::Kind::voronoi, {9, 7, 5}, 4, 1);
  FactorizationGrid grid(e.f);
  BoxQuery q(grid, e.lookup, e.num_sources);
  EXPECT_THROW(q.hybrid({{0, 0, 0}, {10, 7, 5}}), Error);
  EXPECT_THROW(q.naive({{3, 0, 0}, {3, 7, 5}}), Error);
  EXPECT_THROW(q.footprint({{-1, 0, 0}, {3, 7, 5}}), Error);
  EXPECT_THROW(parse_query_method("fast"), Error);
  EXPECT_EQ(parse_query_method("naive"), QueryMethod::naive);
  EXPECT_EQ(parse_query_method("coarse"), QueryMethod::coarse);
}

}  // namespace
}  // namespace strata::mixture
