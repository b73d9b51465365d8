// The Mixture Graph's invariants on label volumes like real superpixel stacks: distinct
// predecessors that come earlier (topological order), bins and weights in range, and level 0
// decoding bit for bit, over many generated volumes with thousands of labels and a crop of the
// real superpixel volume on which the dense-mixture path once merged a node with itself.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/factorize.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/schedule.hpp"
#include "support/test_support.hpp"

namespace strata::mixture {
namespace {

// Every voxel of every level reconstructs to a normalised mixture, and level 0 is exact.
void expect_exact_level0_and_normalised(const HistogramMipmap& h, const Factorization& f) {
  const MixtureLookup lut = MixtureLookup::build(f.graph, make_schedule(f.graph));
  const ErrorReport e = measure_error(h, f, lut);
  EXPECT_EQ(e.level_max_l1[0], 0.0);
  for (std::uint64_t node = 0; node < lut.node_count(); ++node) {
    double total = 0.0;
    for (double w : lut.mean_weights(std::uint32_t(node))) total += w;
    ASSERT_NEAR(total, 1.0, 1e-12) << "node " << node;
  }
}

// fibsem_medulla_250_sp, x 25..44, y 200..219, z 75..94: its sections come in pairs with the same
// partition, so level-1 voxels hold exact 1:1 mixtures, and one level-2 voxel has children with
// nodes A, B and C = (A, B, w = 1/2). Merging A and B (one child each) returned C, which was
// then merged with the other copy of C: node (C, C), rejected when the file was read back.
TEST(MixtureFactorizeInvariants, SuperpixelCropWhereAMergeMetItsOwnResult) {
  const Volume labels = io::read_volume(test::test_data("fibsem_medulla_sp_crop20.nrrd"));
  ASSERT_EQ(labels.dims(), (Extent{20, 20, 20}));
  LabelMap map;
  const HistogramMipmap h = HistogramMipmap::from_labels(labels, &map);
  EXPECT_EQ(h.num_sources(), 81u);
  const Factorization f = factorize(h, {});
  EXPECT_GT(f.stats.dense_mixtures, 0u);
  EXPECT_NO_THROW(validate(f.graph));
  EXPECT_TRUE(map.decode(f.levels[0].ids, labels.dims()) == labels);
  expect_exact_level0_and_normalised(h, f);

  test::TempDir dir;
  const EncodeReport report = encode_labels(labels, dir / "sp.strata");
  EXPECT_LT(*report.max_l1, 0.005);  // 9-bit weights: the paper's bound
  const EncodedLabels encoded(dir / "sp.strata");
  EXPECT_TRUE(encoded.decode_level0() == labels);
}

// validate() names the node and the broken rule.
TEST(MixtureFactorizeInvariants, ValidateRejectsBrokenGraphs) {
  MixtureGraph g;
  g.num_sources = 3;
  g.codebook.bits = 2;
  g.codebook.value = {0.1, 0.2, 0.3, 0.5};
  g.codebook.sigma = {0.0, 0.01, 0.0, 0.0};
  g.nodes = {{0, 1, 0}, {3, 2, 1}};
  EXPECT_NO_THROW(validate(g));

  MixtureGraph self = g;
  self.nodes[1] = {3, 3, 1};
  EXPECT_NE(test::error_of([&] { validate(self); }).find("node 4 has predecessors (3, 3)"), std::string::npos);
  MixtureGraph forward = g;
  forward.nodes[0] = {0, 4, 1};  // refers to a later node: not a topological order
  EXPECT_NE(test::error_of([&] { validate(forward); }).find("node 3 has predecessors (0, 4)"), std::string::npos);
  MixtureGraph bin = g;
  bin.nodes[1].bin = 4;
  EXPECT_NE(test::error_of([&] { validate(bin); }).find("weight bin 4"), std::string::npos);
  MixtureGraph weight = g;
  weight.codebook.value[2] = 0.75;  // symmetric layout: weights are in (0, 0.5]
  EXPECT_NE(test::error_of([&] { validate(weight); }).find("codebook weight 2"), std::string::npos);
  weight.codebook.layout = WeightBins::uniform;
  EXPECT_NO_THROW(validate(weight));
  MixtureGraph sigma = g;
  sigma.codebook.sigma[1] = -0.5;
  EXPECT_NE(test::error_of([&] { validate(sigma); }).find("codebook sigma 1"), std::string::npos);
}

// Randomised: generated superpixel stacks (the kind that broke the dense path), Voronoi cells
// and fibres, thousands of labels, under random factorisation options. Seeded: reproducible.
TEST(MixtureFactorizeInvariants, RandomLabelVolumesUnderRandomOptions) {
  std::mt19937 rng(20261124);
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  const PairScore scores[] = {PairScore::reduction, PairScore::occurrence, PairScore::reuse};
  std::uint32_t most_sources = 0;
  int dense_volumes = 0;
  for (int round = 0; round < 30; ++round) {
    gen::Params p;
    const int kind = round % 5;  // superpixels three times out of five
    p.kind = kind < 3 ? gen::Kind::superpixels : (kind == 3 ? gen::Kind::voronoi : gen::Kind::fibres);
    p.dims = {pick(20, 56), pick(20, 56), pick(16, 48)};
    p.seed = std::uint64_t(pick(1, 1 << 30));
    p.count = p.kind == gen::Kind::superpixels ? pick(12, 120) : pick(1000, 4000);
    FactorOptions o;
    o.score = scores[pick(0, 2)];
    o.bits = std::array{4, 6, 9, 12}[std::size_t(pick(0, 3))];
    o.bins = pick(0, 3) == 0 ? WeightBins::uniform : WeightBins::symmetric;
    o.tau = std::uint32_t(pick(0, 5));
    o.dense_threshold = std::array{8u, 8u, 4u, 16u}[std::size_t(pick(0, 3))];
    SCOPED_TRACE(std::string(gen::kind_name(p.kind)) + " " + p.dims.to_string() + " seed " + std::to_string(p.seed) +
                 " count " + std::to_string(p.count) + " " + std::string(pair_score_name(o.score)) + " bits " +
                 std::to_string(o.bits) + " " + std::string(weight_bins_name(o.bins)) + " tau " +
                 std::to_string(o.tau) + " dense " + std::to_string(o.dense_threshold));
    const Volume labels = gen::generate(p);
    LabelMap map;
    const HistogramMipmap h = HistogramMipmap::from_labels(labels, &map);
    const Factorization f = factorize(h, o);
    ASSERT_NO_THROW(validate(f.graph));
    ASSERT_TRUE(map.decode(f.levels[0].ids, labels.dims()) == labels);
    expect_exact_level0_and_normalised(h, f);
    most_sources = std::max(most_sources, h.num_sources());
    dense_volumes += f.stats.dense_mixtures > 0;
  }
  EXPECT_GT(most_sources, 3000u);  // "many thousand labels"
  EXPECT_GT(dense_volumes, 15);    // the children-merge path ran on most volumes
}

// The same through the file: encode, read back (the reader checks the graph), decode level 0.
TEST(MixtureFactorizeInvariants, GeneratedSuperpixelStacksRoundTripThroughTheFile) {
  test::TempDir dir;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    gen::Params p;
    p.kind = gen::Kind::superpixels;
    p.dims = {48, 51, 43};
    p.seed = seed;
    p.count = 40;  // ~1,700 labels
    const Volume labels = gen::generate(p);
    const auto path = dir / ("sp" + std::to_string(seed) + ".strata");
    EncodeOptions o;
    o.measure_error = false;
    const EncodeReport report = encode_labels(labels, path, o);
    EXPECT_GT(report.sources, 1500u);
    const EncodedLabels encoded(path);
    EXPECT_NO_THROW(validate(encoded.graph()));
    EXPECT_TRUE(encoded.decode_level0() == labels) << "seed " << seed;
  }
}

}  // namespace
}  // namespace strata::mixture
