// Every kind: the same seed gives the same bytes, another seed other bytes, and any slab
// partition or thread count gives the bytes of the whole volume.
#include <gtest/gtest.h>

#include "gen/gen_test_util.hpp"
#include "gen/slice_generator.hpp"
#include "strata/core/threads.hpp"

namespace strata::gen {
namespace {

class GenEveryKind : public ::testing::TestWithParam<Kind> {};

// Odd sizes so rows, tiles and task blocks do not line up with anything.
constexpr Extent kDims{37, 29, 23};

TEST_P(GenEveryKind, SameSeedSameBytes) {
  const Volume a = generate(helpers::params(GetParam(), kDims, 7));
  const Volume b = generate(helpers::params(GetParam(), kDims, 7));
  EXPECT_EQ(a.dims(), kDims);
  EXPECT_TRUE(a == b);
}

TEST_P(GenEveryKind, SlabsOfAnyPartitionMatchTheWhole) {
  auto g = make_generator(helpers::params(GetParam(), kDims, 3));
  const Volume whole = g->slab(0, kDims.z);
  EXPECT_TRUE(helpers::assemble(*g, {0, 1, 2, 9, 10, 22, 23}) == whole);
  EXPECT_TRUE(helpers::assemble(*g, {0, 16, 23}) == whole);
  std::vector<std::int64_t> single_slices;
  for (std::int64_t z = 0; z <= kDims.z; ++z) single_slices.push_back(z);
  EXPECT_TRUE(helpers::assemble(*g, single_slices) == whole);
}

TEST_P(GenEveryKind, ThreadCountDoesNotChangeBytes) {
  const auto p = helpers::params(GetParam(), {70, 40, 12}, 5);
  set_thread_count(1);
  const Volume one = generate(p);
  set_thread_count(3);
  const Volume three = generate(p);
  set_thread_count(0);
  EXPECT_TRUE(one == three);
}

TEST_P(GenEveryKind, RowBlocksJoinSeamlessly) {
  // Slices are computed in blocks of rows (several per slice when wide); any block size must
  // give the same bytes.
  auto g = make_generator(helpers::params(GetParam(), {61, 45, 6}, 9));
  const auto* blocks = dynamic_cast<const detail::SliceGenerator*>(g.get());
  ASSERT_NE(blocks, nullptr);
  const Volume whole = blocks->slab_in_blocks(0, 6, 45);
  EXPECT_TRUE(blocks->slab_in_blocks(0, 6, 1) == whole);
  EXPECT_TRUE(blocks->slab_in_blocks(0, 6, 7) == whole);
  EXPECT_TRUE(blocks->slab_in_blocks(2, 6, 16) == whole.crop({{0, 0, 2}, {61, 45, 6}}));
}

TEST_P(GenEveryKind, DegenerateShapes) {
  for (const Extent d : {Extent{1, 1, 1}, Extent{200, 1, 3}, Extent{1, 50, 1}, Extent{2, 2, 90}}) {
    auto g = make_generator(helpers::params(GetParam(), d, 2));
    const Volume whole = g->slab(0, d.z);
    EXPECT_EQ(whole.dims(), d);
    EXPECT_TRUE(helpers::assemble(*g, {0, d.z / 2, d.z}) == whole) << d.to_string();
  }
}

INSTANTIATE_TEST_SUITE_P(Kinds, GenEveryKind,
                         ::testing::Values(Kind::prisms, Kind::marschner_lobb, Kind::sphere, Kind::voronoi, Kind::fibres,
                                           Kind::superpixels),
                         [](const auto& info) {
                           std::string name(kind_name(info.param));
                           std::erase(name, '-');
                           return name;
                         });

class GenSeededKind : public ::testing::TestWithParam<Kind> {};

TEST_P(GenSeededKind, OtherSeedOtherBytes) {
  const Volume a = generate(helpers::params(GetParam(), kDims, 7));
  const Volume b = generate(helpers::params(GetParam(), kDims, 8));
  EXPECT_FALSE(a == b);
}

INSTANTIATE_TEST_SUITE_P(Kinds, GenSeededKind,
                         ::testing::Values(Kind::prisms, Kind::voronoi, Kind::fibres, Kind::superpixels),
                         [](const auto& info) { return std::string(kind_name(info.param)); });

}  // namespace
}  // namespace strata::gen
