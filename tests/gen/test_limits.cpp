// The generators refuse, before any work, what they cannot stream in bounded memory: products of
// dims beyond 2^60 voxels, slices beyond kMaxSliceBytes, counts beyond the voxels, and objects
// placed up front beyond kMaxSetupBytes. Everything else of any depth streams.
#include <gtest/gtest.h>

#include "gen/gen_test_util.hpp"
#include "strata/core/error.hpp"
#include "support/test_support.hpp"

namespace strata::gen {
namespace {

using helpers::params;
using test::parameter_of;

TEST(GenLimits, DimsWhoseProductOverflowsAreRefused) {
  const std::int64_t big = std::int64_t(1) << 32;
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::prisms, {big, big, big})); }), "Params::dims");
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::sphere, {big, 2, big})); }), "Params::dims");
}

TEST(GenLimits, SlicesBeyondTheStreamingLimitAreRefused) {
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::sphere, {100000, 100000, 1})); }), "Params::dims");
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::voronoi, {16384, 16384, 1})); }), "Params::dims");  // 1 GiB of u32
  Params wide = params(Kind::prisms, {8192, 8192, 1});                                                   // 128 MiB of u16
  EXPECT_EQ(parameter_of([&] { validate(wide); }), "");
  wide.output_dtype = DType::f64;  // 512 MiB
  EXPECT_EQ(parameter_of([&] { validate(wide); }), "Params::dims");
}

TEST(GenLimits, CountsBeyondTheVoxelsAreRefused) {
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::voronoi, {16, 16, 16}, 1, 100000000)); }), "Params::count");
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::fibres, {16, 16, 16}, 1, 4097)); }), "Params::count");
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::superpixels, {16, 16, 64}, 1, 257)); }), "Params::count");
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::voronoi, {16, 16, 16}, 1, 4096)); }), "");
}

TEST(GenLimits, ObjectsPlacedUpFrontAreBounded) {
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::prisms, {1000000, 1000000, 1000000})); }), "Params::dims");
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::prisms, {64, 64, std::int64_t(1) << 32})); }), "Params::dims");
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::fibres, {4096, 4096, 1 << 20}, 1, 10000000)); }), "Params::count");
  // The default count fits: a huge count is blamed.
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::prisms, {256, 256, 256}, 1, 16000000)); }), "Params::count");
  // Sizes the project uses stay allowed.
  for (Kind k : {Kind::prisms, Kind::voronoi, Kind::fibres, Kind::superpixels, Kind::sphere})
    EXPECT_EQ(parameter_of([&] { validate(params(k, {1024, 1024, 1024})); }), "") << kind_name(k);
  // Analytic kinds and superpixels place nothing: any depth.
  EXPECT_EQ(parameter_of([&] { validate(params(Kind::marschner_lobb, {64, 64, std::int64_t(1) << 40})); }), "");
}

TEST(GenLimits, ValidationNeverAllocatesTheVolume) {
  // Refused in constant time, not after placing 10^8 sites.
  EXPECT_THROW(make_generator(params(Kind::voronoi, {16, 16, 16}, 1, 100000000)), ParameterError);
}

}  // namespace
}  // namespace strata::gen
