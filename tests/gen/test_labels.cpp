// Label kinds: ids, background and membrane properties.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "gen/gen_test_util.hpp"

namespace strata::gen {
namespace {

TEST(GenVoronoi, EveryCellPresentAndMembranesThin) {
  const Volume v = generate(helpers::params(Kind::voronoi, {64, 64, 64}, 1, 16));
  ASSERT_EQ(v.dtype(), DType::u32);
  const auto labels = helpers::distinct_labels(v);
  EXPECT_EQ(labels.size(), 17u);  // 0 and 1..16
  for (std::uint32_t id = 0; id <= 16; ++id) EXPECT_TRUE(labels.count(id)) << "missing id " << id;
  const double membranes = helpers::zero_fraction(v);
  EXPECT_GT(membranes, 0.03);
  EXPECT_LT(membranes, 0.25);
}

// Thin (1.5 voxels across, a little more where the warp stretches): nearly every membrane
// voxel has a cell voxel among its 6 face neighbours, and all but junction voxels among 26.
TEST(GenVoronoi, MembraneVoxelsBorderCells) {
  const Extent d{48, 48, 48};
  const Volume v = generate(helpers::params(Kind::voronoi, d, 4, 24));
  const auto view = v.view<std::uint32_t>();
  std::int64_t membrane = 0, no_face_cell = 0, no_cell_at_all = 0;
  for (std::int64_t z = 1; z + 1 < d.z; ++z)
    for (std::int64_t y = 1; y + 1 < d.y; ++y)
      for (std::int64_t x = 1; x + 1 < d.x; ++x) {
        if (view(x, y, z) != 0) continue;
        ++membrane;
        const bool face = view(x - 1, y, z) || view(x + 1, y, z) || view(x, y - 1, z) || view(x, y + 1, z) ||
                          view(x, y, z - 1) || view(x, y, z + 1);
        bool any = false;
        for (int k = -1; k <= 1; ++k)
          for (int j = -1; j <= 1; ++j)
            for (int i = -1; i <= 1; ++i) any = any || view(x + i, y + j, z + k);
        no_face_cell += !face;
        no_cell_at_all += !any;
      }
  ASSERT_GT(membrane, 0);
  EXPECT_LT(double(no_face_cell) / double(membrane), 0.08) << no_face_cell << " of " << membrane;
  EXPECT_LT(double(no_cell_at_all) / double(membrane), 0.01) << no_cell_at_all << " of " << membrane;
}

// No two different cells touch face to face: the membranes separate them.
TEST(GenVoronoi, MembranesSeparateCells) {
  const Extent d{48, 48, 48};
  const Volume v = generate(helpers::params(Kind::voronoi, d, 2, 20));
  const auto view = v.view<std::uint32_t>();
  std::int64_t contacts = 0;
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x + 1 < d.x; ++x) {
        const auto check = [&](std::uint32_t a, std::uint32_t b) { contacts += (a && b && a != b); };
        check(view(x, y, z), view(x + 1, y, z));
        if (y + 1 < d.y) check(view(x, y, z), view(x, y + 1, z));
        if (z + 1 < d.z) check(view(x, y, z), view(x, y, z + 1));
      }
  EXPECT_EQ(contacts, 0);
}

TEST(GenVoronoi, IdsStayInRangeForManyCells) {
  const Volume v = generate(helpers::params(Kind::voronoi, {40, 40, 40}, 3, 300));
  const auto labels = helpers::distinct_labels(v);
  EXPECT_LE(*labels.rbegin(), 300u);
  EXPECT_GT(labels.size(), 250u);
}

TEST(GenFibres, BackgroundFractionAtDefaults) {
  for (const Extent d : {Extent{64, 64, 64}, Extent{96, 80, 72}}) {
    const Volume v = generate(helpers::params(Kind::fibres, d));
    const double background = helpers::zero_fraction(v);
    EXPECT_GT(background, 0.80) << d.to_string();
    EXPECT_LT(background, 0.90) << d.to_string();
    EXPECT_LE(*helpers::distinct_labels(v).rbegin(), 200u);
  }
}

TEST(GenFibres, ManyDistinctIds) {
  const Volume v = generate(helpers::params(Kind::fibres, {128, 128, 128}, 1, 2000));
  const auto labels = helpers::distinct_labels(v);
  EXPECT_GT(labels.size(), 1800u);
  EXPECT_LE(*labels.rbegin(), 2000u);
  const double background = helpers::zero_fraction(v);
  EXPECT_GT(background, 0.80);
  EXPECT_LT(background, 0.90);
}

// A fibre is a tube, not scattered voxels: most of its voxels have a same-id neighbour.
TEST(GenFibres, TubesAreConnected) {
  const Extent d{64, 64, 64};
  const Volume v = generate(helpers::params(Kind::fibres, d, 6));
  const auto view = v.view<std::uint32_t>();
  std::int64_t foreground = 0, lonely = 0;
  for (std::int64_t z = 1; z + 1 < d.z; ++z)
    for (std::int64_t y = 1; y + 1 < d.y; ++y)
      for (std::int64_t x = 1; x + 1 < d.x; ++x) {
        const std::uint32_t id = view(x, y, z);
        if (!id) continue;
        ++foreground;
        lonely += !(view(x - 1, y, z) == id || view(x + 1, y, z) == id || view(x, y - 1, z) == id ||
                    view(x, y + 1, z) == id || view(x, y, z - 1) == id || view(x, y, z + 1) == id);
      }
  EXPECT_LT(double(lonely) / double(foreground), 0.01);
}

// Superpixels: no background; every section has its own ids (about `count` of them, each a
// 2D-connected patch in [z * cells + 1, (z + 1) * cells]); runs of sections share a partition,
// and about half of the consecutive pairs start a new one.
TEST(GenSuperpixels, OwnIdsPerSectionAndRunsOfRepeatedPartitions) {
  const Extent d{60, 48, 64};
  const std::int64_t count = 40;
  const Volume v = generate(helpers::params(Kind::superpixels, d, 5, count));
  EXPECT_EQ(helpers::zero_fraction(v), 0.0);
  const auto view = v.view<std::uint32_t>();
  std::set<std::uint32_t> previous;
  std::int64_t cells = 0, repeated = 0;
  for (std::int64_t z = 0; z < d.z; ++z) {
    std::set<std::uint32_t> section;
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) section.insert(view(x, y, z));
    if (z == 0) cells = std::int64_t(*section.rbegin());  // ids of section 0 end at <= cells
    EXPECT_GE(*section.begin(), std::uint32_t(z * cells + 1)) << "section " << z;
    EXPECT_LE(*section.rbegin(), std::uint32_t((z + 1) * cells)) << "section " << z;
    EXPECT_GT(section.size(), std::size_t(count * 8 / 10)) << "section " << z;
    for (std::uint32_t id : section) EXPECT_EQ(previous.count(id), 0u) << "id " << id << " continues into " << z;
    if (z > 0) {
      bool same = true;  // same partition: ids differ by the same offset everywhere
      const std::int64_t offset = std::int64_t(view(0, 0, z)) - std::int64_t(view(0, 0, z - 1));
      for (std::int64_t y = 0; y < d.y && same; ++y)
        for (std::int64_t x = 0; x < d.x && same; ++x)
          same = std::int64_t(view(x, y, z)) - std::int64_t(view(x, y, z - 1)) == offset;
      repeated += same;
    }
    previous = std::move(section);
  }
  EXPECT_GT(repeated, (d.z - 1) / 4);
  EXPECT_LT(repeated, 3 * (d.z - 1) / 4);
}

// A superpixel is one patch: every voxel has a 4-neighbour with its id, but for single-voxel
// slivers at cell corners, which are rare.
TEST(GenSuperpixels, PatchesAreConnectedInTheSection) {
  const Extent d{64, 64, 6};
  const Volume v = generate(helpers::params(Kind::superpixels, d, 2, 100));
  const auto view = v.view<std::uint32_t>();
  std::int64_t lonely = 0;
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 1; y + 1 < d.y; ++y)
      for (std::int64_t x = 1; x + 1 < d.x; ++x) {
        const std::uint32_t id = view(x, y, z);
        lonely += !(view(x - 1, y, z) == id || view(x + 1, y, z) == id || view(x, y - 1, z) == id ||
                    view(x, y + 1, z) == id);
      }
  EXPECT_LT(double(lonely) / double(d.voxel_count()), 0.001);
}

}  // namespace
}  // namespace strata::gen
