// Box query sigmas are honest: over many random boxes the errors against exact counts fall
// outside 3 sigma for at most 0.5% of (label, box) pairs (a Gaussian gives 0.27%) and never
// outside 6 sigma; on generated volumes (always) and on the shared real label volumes (when
// present). The scoring itself is checked on hand-made histograms.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/query_calibration.hpp"
#include "support/test_support.hpp"

namespace strata::mixture {
namespace {

TEST(MixtureQueryCalibration, ScoresEveryLabelOfEitherHistogram) {
  const Box box{{0, 0, 0}, {4, 4, 4}};
  BoxHistogram exact, estimate;
  exact.box = estimate.box = box;
  exact.counts = {{1, 30.0, 0.0}, {2, 20.0, 0.0}, {5, 14.0, 0.0}};
  estimate.counts = {{1, 31.5, 1.0}, {2, 20.0, 0.0}, {3, 0.5, 0.25}, {5, 12.0, 0.0}};
  QueryCalibration c;
  c.add(estimate, exact);
  EXPECT_EQ(c.pairs, 4u);
  // z: source 1 1.5; source 2 0 (exact, sigma 0); source 3 2; source 5 +inf (error 2, sigma 0).
  EXPECT_EQ(c.outside[0], 3u);  // > 1
  EXPECT_EQ(c.outside[1], 1u);  // > 2: only the infinite one (source 3 is exactly 2)
  EXPECT_EQ(c.outside[5], 1u);
  EXPECT_TRUE(std::isinf(c.worst_z));
  EXPECT_EQ(c.worst_source, 5u);
  EXPECT_DOUBLE_EQ(c.abs_error_sum, 1.5 + 0.0 + 0.5 + 2.0);
  EXPECT_DOUBLE_EQ(c.share_outside(1), 0.75);

  BoxHistogram missing = estimate;  // a label the estimate misses counts with estimate 0
  missing.counts = {{1, 30.0, 0.5}, {2, 20.0, 0.0}};
  QueryCalibration m;
  m.add(missing, exact);
  EXPECT_EQ(m.pairs, 3u);
  EXPECT_EQ(m.worst_source, 5u);
  EXPECT_EQ(m.worst_exact, 14.0);

  BoxHistogram other = exact;
  other.box = {{0, 0, 0}, {4, 4, 5}};
  EXPECT_THROW(c.add(estimate, other), Error);
  EXPECT_THROW(c.share_outside(7), Error);
}

// The acceptance bounds: at most 0.5% of pairs outside 3 sigma, none outside 6.
void expect_honest(const QueryCalibration& c, const std::string& name) {
  std::printf("[ sigma    ] %-36s %7llu pairs, outside 1/2/3/6 sigma %5.2f%% %5.2f%% %6.3f%% %6.3f%%, worst %.2f\n",
              name.c_str(), (unsigned long long)c.pairs, 100 * c.share_outside(1), 100 * c.share_outside(2),
              100 * c.share_outside(3), 100 * c.share_outside(6), c.worst_z);
  EXPECT_LE(c.share_outside(3), 0.005) << name;
  EXPECT_EQ(c.outside[5], 0u) << name << ": worst " << c.worst_z << " sigma, source " << c.worst_source << " in "
                              << c.worst_box.to_string() << ": " << c.worst_estimate << " +- " << c.worst_sigma
                              << ", exact " << c.worst_exact;
}

// A label volume encoded into a file (the reader's codebook, 20-bit codes, is what users query).
struct EncodedFile {
  test::TempDir dir;
  std::unique_ptr<EncodedLabels> labels;
  std::unique_ptr<BoxQuery> query;
  explicit EncodedFile(const Volume& volume) {
    EncodeOptions o;
    o.measure_error = false;
    encode_labels(volume, dir / "labels.strata", o);
    labels = std::make_unique<EncodedLabels>(dir / "labels.strata");
    query = std::make_unique<BoxQuery>(*labels, labels->lookup(), labels->graph().num_sources);
  }
};

// Calibrates `method` over random boxes of an encoded file and checks the bounds.
QueryCalibration calibrate_file(const EncodedFile& file, const std::string& name, std::vector<std::int64_t> sizes,
                                int boxes_per_size, QueryMethod method = QueryMethod::hybrid) {
  QueryOptions options;
  options.method = method;
  options.max_samples = 512;  // coarse: few cells, so most of a box's cells are partly covered
  const QueryCalibration c = calibrate(*file.query, sizes, boxes_per_size, 42, options);
  expect_honest(c, name + " " + std::string(query_method_name(method)));
  return c;
}

TEST(MixtureQueryCalibration, GeneratedLabelVolumes) {
  struct Case {
    gen::Kind kind;
    Extent dims;
    std::int64_t count;
  };
  const Case cases[] = {{gen::Kind::superpixels, {96, 90, 64}, 60},
                        {gen::Kind::voronoi, {96, 96, 80}, 400},
                        {gen::Kind::fibres, {96, 96, 96}, 1500}};
  for (const Case& k : cases) {
    gen::Params p;
    p.kind = k.kind;
    p.dims = k.dims;
    p.count = k.count;
    p.seed = 3;
    const EncodedFile file(gen::generate(p));
    for (QueryMethod m : {QueryMethod::hybrid, QueryMethod::coarse}) {
      const QueryCalibration c = calibrate_file(file, std::string(gen::kind_name(k.kind)), {8, 16, 32, 64}, 20, m);
      EXPECT_GT(c.pairs, 2000u);
    }
  }
}

TEST(MixtureQueryCalibration, RealSuperpixelCrop) {
  const EncodedFile file(io::read_volume(test::test_data("fibsem_medulla_sp_crop20.nrrd")));
  const QueryCalibration c = calibrate_file(file, "fibsem_medulla_sp_crop20", {4, 8, 12, 16}, 40);
  EXPECT_GT(c.pairs, 500u);
}

// The measurement: 30 boxes each of 64^3 and 128^3 on the shared medulla segmentations.
TEST(MixtureQueryCalibration, SharedMedullaSegmentations) {
  int found = 0;
  for (const char* name : {"fibsem_medulla_250_gt.nrrd", "fibsem_medulla_250_ws.nrrd", "fibsem_medulla_250_sp.nrrd"}) {
    const auto path = test::shared_data(name);
    if (!path) continue;
    ++found;
    const EncodedFile file(io::read_volume(*path));
    for (QueryMethod m : {QueryMethod::hybrid, QueryMethod::coarse}) calibrate_file(file, name, {64, 128}, 30, m);
  }
  if (!found) GTEST_SKIP() << "shared label volumes not available";
}

// The coarse method near the far border of odd-sized volumes: there a cell's Eq. 4 mixture
// weighs its voxels unequally (children of unequal length get equal weights), so it is not the
// histogram of its support; sigma must cover that. Boxes ending at the far corner, few cells.
TEST(MixtureQueryCalibration, CoarseAtTheFarBorderOfOddSizes) {
  gen::Params p;
  p.kind = gen::Kind::voronoi;
  p.dims = {75, 70, 61};  // 75 = 64 + 8 + 2 + 1: cut cells at every level
  p.count = 300;
  p.seed = 9;
  const EncodedFile file(gen::generate(p));
  std::mt19937_64 rng(5);
  QueryCalibration c;
  for (std::uint64_t budget : {8, 64, 512})
    for (int i = 0; i < 30; ++i) {
      auto start = [&](std::int64_t dim) { return std::uniform_int_distribution<std::int64_t>(0, dim - 1)(rng); };
      const Box box{{start(p.dims.x), start(p.dims.y), start(p.dims.z)}, p.dims};
      c.add(file.query->coarse(box, budget), file.query->naive(box));
    }
  expect_honest(c, "far-border boxes coarse");
  EXPECT_GT(c.pairs, 1000u);
}

}  // namespace
}  // namespace strata::mixture
