// Greedy factorisation: the paper's worked examples, score semantics, node dedupe, bounds.
#include <gtest/gtest.h>

#include <random>
#include <set>

#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/mixture/factorize.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/schedule.hpp"

namespace strata::mixture {
namespace {


std::uint32_t add(MixtureTable& t, std::vector<std::uint32_t> ix, std::vector<double> ms) {
  MixtureTable::canonicalize(ms, t.integral());
  return t.intern(ix, ms);
}

FactorOptions options(PairScore s, std::uint32_t tau = 3) {
  FactorOptions o;
  o.score = s;
  o.tau = tau;
  return o;
}

// The node merging x (mass mx) and y (mass my) becomes, in the given layout.
InternalNode expected(std::uint32_t x, std::uint32_t y, double mx, double my, WeightBins layout = WeightBins::symmetric) {
  const Interpolation it = orient(x, y, mx, my, 9, layout);
  return {it.a, it.b, it.bin};
}

const PairScore kScores[] = {PairScore::occurrence, PairScore::reduction, PairScore::reuse};

TEST(MixtureQuantize, SymmetricBinsAreCentredOnDyadics) {
  // w in (0, 0.5]; bin q is centred on (q + 1) / 2^(bits+1).
  EXPECT_EQ(quantize_weight(0.5, 9), 511u);
  EXPECT_EQ(quantize_weight(0.25, 9), 255u);
  EXPECT_EQ(bin_center(255, 9), 0.25);
  EXPECT_EQ(quantize_weight(1e-9, 9), 0u);
  EXPECT_EQ(quantize_weight(1.4 / 1024, 9), 0u);
  EXPECT_EQ(quantize_weight(1.6 / 1024, 9), 1u);
  EXPECT_EQ(bin_range(0, 9), (std::pair<double, double>{0.0, 1.5 / 1024}));
  EXPECT_EQ(bin_range(511, 9), (std::pair<double, double>{511.5 / 1024, 0.5}));
  EXPECT_EQ(quantize_weight(0.3, 1), 0u);  // bits 1: bins [0, 0.375), [0.375, 0.5]
  EXPECT_EQ(quantize_weight(0.4, 1), 1u);
  for (std::uint32_t q = 0; q < 512; ++q) {
    const auto [lo, hi] = bin_range(q, 9);
    EXPECT_EQ(quantize_weight(bin_center(q, 9), 9), q);
    EXPECT_EQ(quantize_weight(std::nextafter(hi, 0.0), 9), q);
    EXPECT_LT(lo, hi);
  }
  // Orientation: the lighter side carries the weight; ties keep a < b.
  const Interpolation it = orient(7, 3, 1.0, 3.0, 9, WeightBins::symmetric);
  EXPECT_EQ(it.a, 3u);
  EXPECT_EQ(it.b, 7u);
  EXPECT_DOUBLE_EQ(it.w, 0.25);
  const Interpolation tie = orient(7, 3, 2.0, 2.0, 9, WeightBins::symmetric);
  EXPECT_EQ(tie.a, 3u);
  EXPECT_EQ(tie.bin, 511u);
  EXPECT_EQ(parse_weight_bins("uniform"), WeightBins::uniform);
  EXPECT_THROW(parse_weight_bins("log"), Error);
}

TEST(MixtureQuantize, UniformBinsAndMirror) {
  const WeightBins u = WeightBins::uniform;
  EXPECT_EQ(quantize_weight(0.5, 9, u), 256u);
  EXPECT_EQ(quantize_weight(1e-9, 9, u), 0u);
  EXPECT_EQ(quantize_weight(1.0 - 1e-12, 9, u), 511u);
  EXPECT_EQ(quantize_weight(0.3, 1, u), 0u);
  EXPECT_EQ(quantize_weight(0.7, 1, u), 1u);
  EXPECT_EQ(quantize_weight(0.7, 16, u), std::uint32_t(0.7 * 65536));
  for (double w : {0.1, 0.3337, 0.61, 0.999}) EXPECT_EQ(quantize_weight(1.0 - w, 9, u), mirror_bin(quantize_weight(w, 9, u), 9));
  const Interpolation it = orient(7, 3, 1.0, 3.0, 9, u);  // canonical a < b
  EXPECT_EQ(it.a, 3u);
  EXPECT_DOUBLE_EQ(it.w, 0.25);
  EXPECT_EQ(parse_pair_score("phi2"), PairScore::reduction);
  EXPECT_THROW(parse_pair_score("best"), Error);
}

// Fig. 2: m = (0.1, 0.2, 0.3, 0.4) factors as (1,2), then (3,5), then (4,6) (1-based).
TEST(MixtureFactorize, PaperFigure2) {
  for (WeightBins layout : {WeightBins::symmetric, WeightBins::uniform}) {
    for (bool integral : {true, false}) {
      for (PairScore s : kScores) {
        MixtureTable t(4, integral);
        const auto id = integral ? add(t, {0, 1, 2, 3}, {1, 2, 3, 4}) : add(t, {0, 1, 2, 3}, {0.1, 0.2, 0.3, 0.4});
        FactorOptions o = options(s);
        o.bins = layout;
        const Factorization f = factorize(t, o);
        ASSERT_EQ(f.graph.nodes.size(), 3u) << pair_score_name(s);
        // Masses as the factorisation sees them (0.1 + 0.2 != 0.3 in doubles).
        const std::vector<double> ms = integral ? std::vector<double>{1, 2, 3, 4} : std::vector<double>{0.1, 0.2, 0.3, 0.4};
        EXPECT_EQ(f.graph.nodes[0], expected(0, 1, ms[0], ms[1], layout));  // lambda_5 = (1, 2) / 3
        EXPECT_EQ(f.graph.nodes[1], expected(2, 4, ms[2], ms[0] + ms[1], layout));  // lambda_6 = (e3 + lambda_5) / 2
        EXPECT_EQ(f.graph.nodes[2], expected(3, 5, ms[3], ms[2] + (ms[0] + ms[1]), layout));  // 0.4 e4 + 0.6 lambda_6
        EXPECT_EQ(f.node_of_mixture[id], 6u);
        EXPECT_EQ(f.stats.depth, 3u);
        EXPECT_EQ(f.stats.steps, 3u);
        // Each bin holds a single exact weight, so the codebook reproduces it.
        const bool sym = layout == WeightBins::symmetric;
        EXPECT_DOUBLE_EQ(f.graph.weight(4), sym ? 1.0 / 3.0 : 2.0 / 3.0);
        EXPECT_DOUBLE_EQ(f.graph.weight(6), sym ? 0.4 : 0.6);
        EXPECT_EQ(f.graph.sigma(4), 0.0);
        const MixtureLookup lut = MixtureLookup::build(f.graph, make_schedule(f.graph));
        const SparseMixture m = lut.mean(6);
        EXPECT_NEAR(m.weight(0), 0.1, 1e-15);
        EXPECT_NEAR(m.weight(1), 0.2, 1e-15);
        EXPECT_NEAR(m.weight(2), 0.3, 1e-15);
        EXPECT_NEAR(m.weight(3), 0.4, 1e-15);
      }
    }
  }
  // Symmetric layout: the lighter predecessor carries the weight.
  MixtureTable t(4, true);
  add(t, {0, 1, 2, 3}, {1, 2, 3, 4});
  const Factorization f = factorize(t, {});
  EXPECT_EQ(f.graph.nodes[0].a, 1u);
  EXPECT_EQ(f.graph.nodes[0].b, 0u);
}

// Fig. 4: with m' = (0.2, 0.4, 0.1, 0.3) the interpolation lambda_5 of (1,2) at 1:2 serves both.
// Every pair is held by both mixtures (phi1 and phi2 tie); only (1,2) has the same ratio in
// both, so it saves a node and is picked first.
TEST(MixtureFactorize, PaperFigure4ReusesLambda5) {
  for (PairScore s : kScores) {
    MixtureTable t(4, true);
    const auto m = add(t, {0, 1, 2, 3}, {1, 2, 3, 4});
    const auto mp = add(t, {0, 1, 2, 3}, {2, 4, 1, 3});
    const Factorization f = factorize(t, options(s));
    ASSERT_GE(f.graph.nodes.size(), 1u);
    EXPECT_EQ(f.graph.nodes[0], expected(0, 1, 1, 2)) << pair_score_name(s);
    EXPECT_EQ(f.stats.merges, 6u);
    EXPECT_EQ(f.stats.reused, 1u);
    EXPECT_EQ(f.graph.nodes.size(), 5u);
    // Both roots reach node 4 (lambda_5).
    const MixtureLookup lut = MixtureLookup::build(f.graph, make_schedule(f.graph));
    for (auto [id, w] : {std::pair{m, std::vector<double>{.1, .2, .3, .4}}, std::pair{mp, std::vector<double>{.2, .4, .1, .3}}}) {
      const SparseMixture r = lut.mean(f.node_of_mixture[id]);
      for (std::uint32_t i = 0; i < 4; ++i) EXPECT_NEAR(r.weight(i), w[i], 2.0 / 512);
      std::vector<std::uint32_t> stack{f.node_of_mixture[id]};
      bool found = false;
      while (!stack.empty()) {
        const std::uint32_t n = stack.back();
        stack.pop_back();
        if (n == 4) found = true;
        if (!f.graph.is_source(n)) stack.push_back(f.graph.node(n).a), stack.push_back(f.graph.node(n).b);
      }
      EXPECT_TRUE(found);
    }
  }
}

// phi1 counts voxels holding a pair; phi2 weights them by nnz - 1 (2 for nnz 2).
TEST(MixtureFactorize, OccurrenceAndReductionDisagreeWhereTheyShould) {
  MixtureTable t(6, true);
  const auto a = add(t, {0, 1}, {1, 1});
  const auto b = add(t, {1, 2, 3, 4, 5}, {1, 2, 3, 4, 5});
  std::vector<std::uint64_t> mult(t.size(), 1);
  mult[a] = 3;  // phi1(0,1) = 3 > 2 = phi1(pairs of b); phi2(0,1) = 6 < 8 = phi2(pairs of b)
  mult[b] = 2;
  t.set_multiplicities(mult);
  const Factorization f1 = factorize(t, options(PairScore::occurrence, 1));
  EXPECT_EQ(f1.graph.nodes[0].a, 0u);
  EXPECT_EQ(f1.graph.nodes[0].b, 1u);
  const Factorization f2 = factorize(t, options(PairScore::reduction, 1));
  EXPECT_NE(f2.graph.nodes[0].a, 0u);
  EXPECT_EQ(f2.graph.nodes[0], expected(1, 2, 1, 2));  // smallest masses among ties
  // With tau = 3 only b votes in stage 1, so phi1 starts inside b too.
  const Factorization f3 = factorize(t, options(PairScore::occurrence, 3));
  EXPECT_EQ(f3.graph.nodes[0], expected(1, 2, 1, 2));
}

// Pair (1,2) occurs in {0,1,2} and in {1,2,3} (same ratio); once picked, ALL occurrences are
// factored - including in a mixture with nnz <= tau that does not vote yet.
TEST(MixtureFactorize, FactorsAllOccurrencesOfThePair) {
  MixtureTable t(5, true);
  add(t, {1, 2, 3, 4}, {1, 1, 5, 7});
  add(t, {1, 2}, {3, 3});
  add(t, {0, 1, 2}, {2, 1, 1});
  const Factorization f = factorize(t, options(PairScore::reduction, 3));
  // First step inside the 4-mixture: (1,2) has the smallest masses; its w = 1/2 for all three.
  EXPECT_EQ(f.graph.nodes[0], (InternalNode{1, 2, 511}));
  EXPECT_EQ(f.node_of_mixture[6], 5u);  // the 2-mixture is exactly that node
  EXPECT_EQ(f.stats.reused, 2u);
}

TEST(MixtureFactorize, WeightQuantizationMergesNodes) {
  MixtureTable t(2, true);
  const auto x = add(t, {0, 1}, {1, 2});        // w = 1/3 on the lighter side
  const auto y = add(t, {0, 1}, {1000, 2001});  // w = 0.33322, same 9-bit bin
  const auto z = add(t, {0, 1}, {1, 3});        // w = 0.25
  const Factorization f = factorize(t, {});
  EXPECT_EQ(f.graph.nodes.size(), 2u);
  EXPECT_EQ(f.node_of_mixture[x], f.node_of_mixture[y]);
  EXPECT_NE(f.node_of_mixture[x], f.node_of_mixture[z]);
  // The bin's code value is the mean of its member weights, sigma their spread.
  const std::uint32_t q = f.graph.node(f.node_of_mixture[x]).bin;
  const double w1 = 1.0 / 3.0, w2 = 1000.0 / 3001.0;
  EXPECT_NEAR(f.graph.codebook.value[q], (w1 + w2) / 2, 1e-15);
  EXPECT_NEAR(f.graph.codebook.sigma[q], std::abs(w1 - w2) / 2, 1e-12);
  EXPECT_EQ(f.graph.codebook.uses[q], 2u);
}

TEST(MixtureFactorize, RejectsBadBits) {
  MixtureTable t(2, true);
  FactorOptions o;
  o.bits = 0;
  EXPECT_THROW(factorize(t, o), Error);
  o.bits = 17;
  EXPECT_THROW(factorize(t, o), Error);
}

// Structural invariants shared by the volume tests.
void check_graph(const MixtureGraph& g) {
  std::set<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> seen;
  for (std::size_t i = 0; i < g.nodes.size(); ++i) {
    const auto& n = g.nodes[i];
    const std::uint32_t id = g.num_sources + std::uint32_t(i);
    ASSERT_NE(n.a, n.b);
    ASSERT_LT(n.a, id);  // predecessors earlier in the list
    ASSERT_LT(n.b, id);
    if (g.codebook.layout == WeightBins::uniform) {
      ASSERT_LT(n.a, n.b);
    }
    ASSERT_LT(n.bin, g.codebook.bins());
    ASSERT_TRUE(seen.insert({n.a, n.b, n.bin}).second) << "duplicate node " << id;
  }
  for (std::uint32_t q = 0; q < g.codebook.bins(); ++q) {
    const auto [lo, hi] = bin_range(q, g.codebook.bits, g.codebook.layout);
    ASSERT_GE(g.codebook.value[q], lo);
    ASSERT_LE(g.codebook.value[q], hi);
    ASSERT_LE(g.codebook.sigma[q], hi - lo);
  }
}

// Voronoi cells: every reconstructed mixture within the quantisation bound of exact H.
// One interpolation with |w - code| < 2^-b moves at most 2 * 2^-b of l1 mass; a mixture
// factored greedily uses nnz - 1 of them (each scaled by the fraction it carries <= 1).
TEST(MixtureFactorize, ReconstructionWithinQuantizationBound) {
  const Volume v = gen::generate(gen::Params{gen::Kind::voronoi, {37, 29, 21}, 5, 40, std::nullopt});
  const HistogramMipmap h = HistogramMipmap::from_labels(v);
  for (PairScore s : kScores)
    for (int bits : {4, 9, 12})
      for (WeightBins layout : {WeightBins::symmetric, WeightBins::uniform}) {
        SCOPED_TRACE(std::string(pair_score_name(s)) + " bits " + std::to_string(bits) + " " +
                     std::string(weight_bins_name(layout)));
        FactorOptions o = options(s);
        o.bits = bits;
        o.bins = layout;
        o.dense_threshold = 0;  // greedy everywhere: the simple bound applies
        const Factorization f = factorize(h, o);
        check_graph(f.graph);
        const MixtureLookup lut = MixtureLookup::build(f.graph, make_schedule(f.graph));
        // Widest bin: uniform 2^-bits; symmetric 1.5 * 2^-(bits+1) (the first one).
        const double step = layout == WeightBins::uniform ? std::ldexp(1.0, -bits) : 1.5 * std::ldexp(1.0, -bits - 1);
        for (std::uint32_t id = 0; id < h.table().size(); ++id) {
          const SparseMixture exact = h.table().mixture(id);
          const SparseMixture rec = lut.mean(f.node_of_mixture[id]);
          const double err = SparseMixture::l1_distance(exact, rec);
          const double bound = 2.0 * step * double(exact.nnz() - 1);
          ASSERT_LE(err, bound + 1e-12) << "mixture " << id << " nnz " << exact.nnz();
          EXPECT_NEAR(rec.total(), 1.0, 1e-12);  // convex combinations stay normalised
        }
        // Level 0 is exact: voxels map to their source nodes.
        EXPECT_EQ(f.levels[0].ids, h.level(0).ids);
        const ErrorReport e = measure_error(h, f, lut);
        EXPECT_EQ(e.level_max_l1[0], 0.0);
        if (bits == 9) {
          EXPECT_LT(e.max_l1, 0.02);
        }
        if (bits == 12) {
          EXPECT_LT(e.max_l1, 0.0025);
        }
      }
}

// Dense mixtures are built from their children's nodes: the error adds at most the
// interpolations of <= 8 children on top of the worst child.
TEST(MixtureFactorize, DenseMixturesViaChildren) {
  const Volume v = gen::generate(gen::Params{gen::Kind::fibres, {40, 36, 30}, 3, 60, std::nullopt});
  const HistogramMipmap h = HistogramMipmap::from_labels(v);
  FactorOptions o;
  o.dense_threshold = 6;
  const Factorization f = factorize(h, o);
  EXPECT_GT(f.stats.dense_mixtures, 0u);
  check_graph(f.graph);
  const MixtureLookup lut = MixtureLookup::build(f.graph, make_schedule(f.graph));
  const ErrorReport e = measure_error(h, f, lut);
  const double step = 1.5 * std::ldexp(1.0, -o.bits - 1);
  for (int l = 1; l < h.level_count(); ++l) {
    const auto& P = h.level(l);
    const auto& C = h.level(l - 1);
    for (std::int64_t z = 0; z < P.dims.z; ++z)
      for (std::int64_t y = 0; y < P.dims.y; ++y)
        for (std::int64_t x = 0; x < P.dims.x; ++x) {
          const std::uint32_t id = P.ids[P.index(x, y, z)];
          if (h.table().nnz(id) <= o.dense_threshold) continue;
          double child_err = 0.0;
          for (std::int64_t cz = 2 * z; cz < std::min(C.dims.z, 2 * z + 2); ++cz)
            for (std::int64_t cy = 2 * y; cy < std::min(C.dims.y, 2 * y + 2); ++cy)
              for (std::int64_t cx = 2 * x; cx < std::min(C.dims.x, 2 * x + 2); ++cx) {
                const std::uint32_t c = C.ids[C.index(cx, cy, cz)];
                child_err = std::max(child_err, SparseMixture::l1_distance(h.table().mixture(c), lut.mean(f.node_of_mixture[c])));
              }
          const double err = SparseMixture::l1_distance(h.table().mixture(id), lut.mean(f.node_of_mixture[id]));
          ASSERT_LE(err, child_err + 2.0 * 7.0 * step + 1e-12) << "level " << l;
        }
  }
  EXPECT_LT(e.max_l1, 0.02);
  // Fewer nodes than factoring the dense mixtures over sources.
  FactorOptions all = o;
  all.dense_threshold = 0;
  const Factorization g = factorize(h, all);
  EXPECT_LT(f.stats.nodes, g.stats.nodes);
}

TEST(MixtureFactorize, DeterministicAndMoveEquivalent) {
  const Volume v = gen::generate(gen::Params{gen::Kind::voronoi, {30, 30, 30}, 9, 25, std::nullopt});
  HistogramMipmap h = HistogramMipmap::from_labels(v);
  const Factorization a = factorize(h, {});
  const Factorization b = factorize(h, {});
  EXPECT_EQ(a.graph.nodes, b.graph.nodes);
  EXPECT_EQ(a.graph.codebook.value, b.graph.codebook.value);
  const Factorization c = factorize(std::move(h), {});
  EXPECT_EQ(a.graph.nodes, c.graph.nodes);
  ASSERT_EQ(a.levels.size(), c.levels.size());
  for (std::size_t l = 0; l < a.levels.size(); ++l) EXPECT_EQ(a.levels[l].ids, c.levels[l].ids);
}

}  // namespace
}  // namespace strata::mixture
