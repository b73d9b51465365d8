// Names, defaults and parameter validation of the generator registry.
#include <gtest/gtest.h>

#include <string>

#include "gen/gen_test_util.hpp"
#include "strata/core/error.hpp"

namespace strata::gen {
namespace {

TEST(GenRegistry, NamesRoundTrip) {
  for (std::string_view name : kind_names()) EXPECT_EQ(kind_name(parse_kind(name)), name);
  EXPECT_EQ(parse_kind("marschner-lobb"), Kind::marschner_lobb);
  EXPECT_EQ(kind_names().size(), 6u);
}

TEST(GenRegistry, UnknownKindListsTheValidOnes) {
  try {
    parse_kind("spheres");
    FAIL() << "expected strata::Error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("spheres"), std::string::npos) << message;
    for (std::string_view name : kind_names()) EXPECT_NE(message.find(name), std::string::npos) << message;
  }
}

TEST(GenRegistry, LabelKinds) {
  EXPECT_TRUE(is_label_kind(Kind::voronoi));
  EXPECT_TRUE(is_label_kind(Kind::fibres));
  EXPECT_TRUE(is_label_kind(Kind::superpixels));
  EXPECT_FALSE(is_label_kind(Kind::prisms));
  EXPECT_FALSE(is_label_kind(Kind::marschner_lobb));
  EXPECT_FALSE(is_label_kind(Kind::sphere));
}

TEST(GenRegistry, DtypesPerKind) {
  const Extent d{8, 6, 4};
  EXPECT_EQ(make_generator(helpers::params(Kind::prisms, d))->info().dtype, DType::u16);
  EXPECT_EQ(make_generator(helpers::params(Kind::marschner_lobb, d))->info().dtype, DType::f32);
  EXPECT_EQ(make_generator(helpers::params(Kind::sphere, d))->info().dtype, DType::f32);
  EXPECT_EQ(make_generator(helpers::params(Kind::voronoi, d))->info().dtype, DType::u32);
  EXPECT_EQ(make_generator(helpers::params(Kind::fibres, d))->info().dtype, DType::u32);
  EXPECT_EQ(make_generator(helpers::params(Kind::superpixels, d))->info().dtype, DType::u32);
  EXPECT_EQ(make_generator(helpers::params(Kind::fibres, d))->info().dims, d);
}

TEST(GenRegistry, RejectsBadParams) {
  EXPECT_THROW(make_generator(helpers::params(Kind::sphere, {0, 4, 4})), Error);
  EXPECT_THROW(make_generator(helpers::params(Kind::sphere, {4, -1, 4})), Error);
  EXPECT_THROW(make_generator(helpers::params(Kind::voronoi, {4, 4, 4}, 1, -3)), Error);
  EXPECT_THROW(make_generator(helpers::params(Kind::fibres, {4, 4, 4}, 1, std::int64_t(1) << 33)), Error);
  // Ids are unique per section: sections x superpixels must fit u32.
  EXPECT_THROW(make_generator(helpers::params(Kind::superpixels, {1 << 16, 1 << 16, 2}, 1, std::int64_t(1) << 31)),
               Error);
}

TEST(GenRegistry, SlabRangeIsChecked) {
  auto g = make_generator(helpers::params(Kind::sphere, {4, 4, 4}));
  EXPECT_THROW(g->slab(-1, 2), Error);
  EXPECT_THROW(g->slab(3, 2), Error);
  EXPECT_THROW(g->slab(0, 5), Error);
  EXPECT_EQ(g->slab(2, 2).voxel_count(), 0);
}

TEST(GenRegistry, DefaultCounts) {
  EXPECT_EQ(default_count(Kind::prisms), 40);
  EXPECT_EQ(default_count(Kind::voronoi), 64);
  EXPECT_EQ(default_count(Kind::fibres), 200);
  EXPECT_EQ(default_count(Kind::superpixels), 256);
}

}  // namespace
}  // namespace strata::gen
