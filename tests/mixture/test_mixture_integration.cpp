// End-to-end on real and synthetic label volumes, fractional input and edge cases.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "strata/core/threads.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/factorize.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/palette.hpp"
#include "strata/mixture/schedule.hpp"
#include "support/test_support.hpp"

namespace strata::mixture {
namespace {

// gala_fibsem_test_gt (200x100x50, 132 neuron ids + background): level 0 decodes bit for bit
// through the label map, the 9-bit round trip stays under the paper's 0.005 max l1 error.
TEST(MixtureIntegration, GalaFibsemRoundTrip) {
  const auto path = test::shared_data("gala_fibsem_test_gt.nrrd");
  if (!path) GTEST_SKIP() << "gala_fibsem_test_gt.nrrd not available";
  const Volume labels = io::read_volume(*path);
  LabelMap map;
  HistogramMipmap h = HistogramMipmap::from_labels(labels, &map);
  EXPECT_GE(h.num_sources(), 132u);
  EXPECT_EQ(h.level_count(), 9);  // 200 -> 100 -> ... -> 1
  const Factorization f = factorize(h, {});
  const Volume decoded = map.decode(f.levels[0].ids, labels.dims());
  EXPECT_TRUE(decoded == labels);
  const Schedule s = make_schedule(f.graph);
  const MixtureLookup lut = MixtureLookup::build(f.graph, s);
  const ErrorReport e = measure_error(h, f, lut);
  EXPECT_EQ(e.level_max_l1[0], 0.0);
  EXPECT_LT(e.max_l1, 0.005);
  EXPECT_EQ(f.stats.depth, s.depth);
  // Far fewer nodes than voxels in the mipmap (1.14 M), more than distinct mixtures / 2.
  const MipmapStats ms = h.stats();
  EXPECT_LT(f.stats.nodes, ms.voxels / 20);
  EXPECT_GT(f.stats.nodes, ms.distinct_mixtures / 2);
  std::printf("[ gala     ] sources %u distinct %llu nodes %llu depth %u max_l1 %.5f mean_l1 %.2e (%.3f s)\n",
              h.num_sources(), (unsigned long long)ms.distinct_mixtures, (unsigned long long)f.stats.nodes,
              f.stats.depth, e.max_l1, e.mean_l1, f.stats.seconds);
}

// Results do not depend on the thread count (interning runs in z order, the greedy serially).
TEST(MixtureIntegration, IndependentOfThreadCount) {
  gen::Params p;
  p.kind = gen::Kind::fibres;
  p.dims = {45, 38, 29};
  p.count = 120;
  const Volume v = gen::generate(p);
  set_thread_count(1);
  const HistogramMipmap h1 = HistogramMipmap::from_labels(v);
  const Factorization f1 = factorize(h1, {});
  set_thread_count(2);
  const HistogramMipmap h2 = HistogramMipmap::from_labels(v);
  const Factorization f2 = factorize(h2, {});
  set_thread_count(0);
  ASSERT_EQ(h1.table().size(), h2.table().size());
  for (int l = 0; l < h1.level_count(); ++l) EXPECT_EQ(h1.level(l).ids, h2.level(l).ids);
  EXPECT_EQ(f1.graph.nodes, f2.graph.nodes);
  EXPECT_EQ(f1.graph.codebook.value, f2.graph.codebook.value);
}

// Fractional input: level-0 voxels that are already mixtures are factored too (level 0 is
// then within the quantisation bound instead of exact).
TEST(MixtureIntegration, FractionalInput) {
  const Extent d{11, 9, 7};
  std::mt19937_64 rng(3);
  FractionalVoxels in;
  in.dims = d;
  in.num_sources = 6;
  for (std::int64_t v = 0; v < d.voxel_count(); ++v) {
    const std::uint32_t base = std::uint32_t((v / 17) % 6);
    in.index.push_back(base);
    in.weight.push_back(1.0);
    if (rng() % 3 == 0) {
      in.index.push_back(std::uint32_t(rng() % 6));
      in.weight.push_back(double(rng() % 1000) / 1000.0);
    }
    in.offsets.push_back(in.index.size());
  }
  const HistogramMipmap h = HistogramMipmap::from_fractional(in);
  ASSERT_TRUE(h.fractional());
  const Factorization f = factorize(h, {});
  const MixtureLookup lut = MixtureLookup::build(f.graph, make_schedule(f.graph));
  const ErrorReport e = measure_error(h, f, lut);
  EXPECT_GT(e.level_max_l1[0], 0.0);  // mixed level-0 voxels are quantised
  const double step = 1.5 * std::ldexp(1.0, -10);
  for (std::uint32_t id = 0; id < h.table().size(); ++id) {
    const double err = SparseMixture::l1_distance(h.table().mixture(id), lut.mean(f.node_of_mixture[id]));
    ASSERT_LE(err, 2.0 * step * (h.table().nnz(id) - 1) + 1e-12);
  }
  // Unit voxels still map to their sources.
  for (std::int64_t v = 0; v < d.voxel_count(); ++v)
    if (in.offsets[std::size_t(v) + 1] - in.offsets[std::size_t(v)] == 1) {
      ASSERT_EQ(f.levels[0].ids[std::size_t(v)], in.index[in.offsets[std::size_t(v)]]);
    }
}

TEST(MixtureIntegration, DegenerateVolumes) {
  // One label: no internal nodes, depth 0, every voxel of every level is source 0.
  Volume c({5, 4, 3}, DType::u16);
  for (auto& x : c.samples<std::uint16_t>()) x = 42;
  const HistogramMipmap h = HistogramMipmap::from_labels(c);
  const Factorization f = factorize(h, {});
  EXPECT_EQ(f.stats.nodes, 1u);
  EXPECT_EQ(f.stats.depth, 0u);
  const Schedule s = make_schedule(f.graph);
  const std::vector<float> rgba{0.1f, 0.2f, 0.3f, 0.4f};
  EXPECT_EQ(propagate_palette(f.graph, s, rgba, 4), rgba);
  for (const auto& L : f.levels)
    for (std::uint32_t id : L.ids) EXPECT_EQ(id, 0u);
  // A single voxel.
  Volume one({1, 1, 1}, DType::i32);
  one.samples<std::int32_t>()[0] = -7;
  const HistogramMipmap h1 = HistogramMipmap::from_labels(one);
  EXPECT_EQ(h1.level_count(), 1);
  EXPECT_EQ(factorize(h1, {}).stats.nodes, 1u);
  // Two labels in a 2x1x1 volume: one interpolation at weight 1/2.
  Volume two({2, 1, 1}, DType::u8);
  two.samples<std::uint8_t>()[1] = 1;
  const Factorization f2 = factorize(HistogramMipmap::from_labels(two), {});
  ASSERT_EQ(f2.graph.nodes.size(), 1u);
  EXPECT_EQ(f2.graph.weight(2), 0.5);
  EXPECT_EQ(f2.levels[1].ids[0], 2u);
}

}  // namespace
}  // namespace strata::mixture
