// Streamed label encoding: label values gathered slab by slab, level 0 never held whole, the
// mipmap's level 1 built as slabs arrive. Every slab size must give the file of the whole volume.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/mixture/label_map.hpp"
#include "strata/store/container.hpp"
#include "support/test_support.hpp"

namespace strata::mixture {
namespace {

using strata::test::error_of;
using strata::test::parameter_of;

Volume fibres(Extent dims, std::int64_t count) {
  gen::Params p;
  p.kind = gen::Kind::fibres;
  p.dims = dims;
  p.count = count;
  return gen::generate(p);
}

// The smallest memory limit encode_labels() accepts for `info`, i.e. the one giving the
// fewest slices per slab (8), found by doubling then bisecting over label_slab_slices().
std::uint64_t smallest_limit(const VolumeInfo& info) {
  const auto accepted = [&](std::uint64_t limit) {
    try {
      label_slab_slices(info, limit);
      return true;
    } catch (const ParameterError&) {
      return false;
    }
  };
  std::uint64_t lo = 1, hi = 1;
  while (!accepted(hi)) lo = hi, hi *= 2;
  while (hi - lo > 1) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    (accepted(mid) ? hi : lo) = mid;
  }
  return hi;
}

// Two label files hold the same graph, label map, ids and metadata (timings aside).
void expect_same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  const store::ContainerReader ra(a), rb(b);
  nlohmann::json ma = ra.metadata(), mb = rb.metadata();
  ma["stats"].erase("factor_seconds");
  mb["stats"].erase("factor_seconds");
  EXPECT_EQ(ma, mb);
  std::vector<std::string> sections{"mixture_graph", "label_map"};
  for (std::size_t l = 0; l < ma["levels"].size(); ++l) sections.push_back("ids_L" + std::to_string(l));
  for (const std::string& s : sections) {
    const auto x = ra.section(s), y = rb.section(s);
    EXPECT_TRUE(std::equal(x.begin(), x.end(), y.begin(), y.end())) << s;
  }
}

TEST(StreamedLabels, EverySlabSizeGivesTheFileOfTheWholeVolume) {
  // 53 slices: 8-slice slabs leave an odd last slab of 5; odd x and y leave partial blocks.
  const Volume labels = fibres({37, 29, 53}, 60);
  test::TempDir dir;
  const std::uint64_t fewest = smallest_limit(labels.info());
  ASSERT_EQ(label_slab_slices(labels.info(), fewest), 8);
  ASSERT_EQ(label_slab_slices(labels.info(), 0), 53);  // 64 MiB slabs: the whole volume
  for (const IdsMode ids : {IdsMode::blocks, IdsMode::fixed}) {
    EncodeOptions whole;
    whole.ids = ids;
    encode_labels(labels, dir / "whole.strata", whole);
    const std::uint64_t per_slice = 37 * 29 * (dtype_size(labels.dtype()) + 4);
    for (const std::uint64_t extra_slices : {0, 8, 16, 40}) {
      EncodeOptions slabs = whole;
      slabs.memory_limit = fewest + extra_slices * per_slice;
      const std::int64_t slices = label_slab_slices(labels.info(), slabs.memory_limit);
      EXPECT_EQ(slices, std::min<std::int64_t>(53, 8 + std::int64_t(extra_slices)));
      const auto file = dir / ("slabs" + std::to_string(slices) + ".strata");
      const std::unique_ptr<io::VolumeSource> source = io::memory_source(labels);
      encode_labels(*source, file, slabs);
      SCOPED_TRACE(std::string(ids_mode_name(ids)) + ", " + std::to_string(slices) + " slices per slab");
      expect_same_file(dir / "whole.strata", file);
      EXPECT_TRUE(EncodedLabels(file).decode_level0() == labels);  // level 0 bit-exact
    }
  }
}

TEST(StreamedLabels, ALimitTooSmallForTheCoarseLevelsIsRefusedByName) {
  const Volume labels = fibres({40, 40, 40}, 20);
  test::TempDir dir;
  const std::uint64_t fewest = smallest_limit(labels.info());
  EncodeOptions o;
  o.memory_limit = fewest - 1;
  EXPECT_EQ(parameter_of([&] { encode_labels(labels, dir / "x.strata", o); }), "EncodeOptions::memory_limit");
  EXPECT_NE(error_of([&] { encode_labels(labels, dir / "x.strata", o); }).find("coarser mip levels"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "x.strata"));
}

TEST(StreamedLabels, MipmapFromSlabsEqualsTheWholeMipmap) {
  const Volume labels = fibres({33, 20, 27}, 40);
  SourceIds s = to_source_ids(labels);
  const HistogramMipmap whole = HistogramMipmap::from_source_ids(s.dims, s.ids, s.map.size());
  HistogramMipmap::StreamBuilder builder(s.dims, s.map.size());
  const std::size_t slice = std::size_t(s.dims.x * s.dims.y);
  std::size_t at = 0;
  for (const std::size_t slices : {2, 6, 2, 10, 7}) {  // uneven, even until the odd last one
    builder.append(std::span(s.ids).subspan(at, slices * slice));
    at += slices * slice;
  }
  const HistogramMipmap streamed = builder.finish();
  EXPECT_TRUE(streamed.level(0).ids.empty());
  EXPECT_EQ(streamed.level(0).dims, s.dims);
  ASSERT_EQ(streamed.level_count(), whole.level_count());
  for (int l = 1; l < whole.level_count(); ++l) EXPECT_EQ(streamed.level(l).ids, whole.level(l).ids) << "level " << l;
  ASSERT_EQ(streamed.table().size(), whole.table().size());
  for (std::uint32_t id = 0; id < whole.table().size(); ++id) {
    ASSERT_EQ(streamed.table().multiplicity(id), whole.table().multiplicity(id)) << "mixture " << id;
    ASSERT_EQ(streamed.table().mixture(id), whole.table().mixture(id)) << "mixture " << id;
  }
  const MipmapStats a = streamed.stats(), b = whole.stats();
  EXPECT_EQ(a.voxels, b.voxels);
  EXPECT_EQ(a.nnz_total, b.nnz_total);
}

// One part of level 1 per slice range, built apart as MPI ranks do.
MipmapSlabPart build_part(const SourceIds& s, std::int64_t z0, std::int64_t z1) {
  HistogramMipmap::StreamBuilder b(s.dims, s.map.size(), z0, z1);
  const std::size_t slice = std::size_t(s.dims.x * s.dims.y);
  for (std::int64_t z = z0; z < z1; z += 8) {  // slabs of 8 slices, the last one shorter
    const std::int64_t n = std::min<std::int64_t>(8, z1 - z);
    b.append(std::span(s.ids).subspan(std::size_t(z) * slice, std::size_t(n) * slice));
  }
  return b.finish_part();
}

TEST(StreamedLabels, PartsBuiltApartMergeToTheWholeMipmap) {
  const Volume labels = fibres({33, 20, 27}, 40);
  const SourceIds s = to_source_ids(labels);
  const HistogramMipmap whole = HistogramMipmap::from_source_ids(s.dims, s.ids, s.map.size());
  const std::size_t slice = std::size_t(s.dims.x * s.dims.y);
  // The first range streamed here, the others merged as parts; then every range a part.
  for (const bool first_streamed : {true, false}) {
    HistogramMipmap::StreamBuilder builder(s.dims, s.map.size());
    if (first_streamed) {
      builder.append(std::span(s.ids).first(8 * slice));
    } else {
      builder.append_part(build_part(s, 0, 8));
    }
    builder.append_part(build_part(s, 8, 24));
    builder.append_part(build_part(s, 24, 27));  // odd end
    const HistogramMipmap merged = builder.finish();
    ASSERT_EQ(merged.level_count(), whole.level_count());
    for (int l = 1; l < whole.level_count(); ++l) EXPECT_EQ(merged.level(l).ids, whole.level(l).ids) << "level " << l;
    ASSERT_EQ(merged.table().size(), whole.table().size());
    for (std::uint32_t id = 0; id < whole.table().size(); ++id) {
      ASSERT_EQ(merged.table().mixture(id), whole.table().mixture(id)) << "mixture " << id;
      ASSERT_EQ(merged.table().multiplicity(id), whole.table().multiplicity(id)) << "mixture " << id;
      // The factorisation reads a mixture's children at its first voxel.
      ASSERT_EQ(merged.table().first_level(id), whole.table().first_level(id)) << "mixture " << id;
      ASSERT_EQ(merged.table().first_voxel(id), whole.table().first_voxel(id)) << "mixture " << id;
    }
  }
}

TEST(StreamedLabels, PartsThatDoNotContinueAreRefused) {
  const Volume labels = fibres({16, 12, 24}, 10);
  const SourceIds s = to_source_ids(labels);
  const MipmapSlabPart middle = build_part(s, 8, 16);
  HistogramMipmap::StreamBuilder builder(s.dims, s.map.size());
  EXPECT_NE(error_of([&] { builder.append_part(middle); }).find("does not continue slice 0"), std::string::npos);
  MipmapSlabPart broken = build_part(s, 0, 8);
  broken.level1_ids.pop_back();
  EXPECT_NE(error_of([&] { builder.append_part(broken); }).find("arrays disagree"), std::string::npos);
  EXPECT_NE(error_of([&] { HistogramMipmap::StreamBuilder(s.dims, s.map.size(), 3, 8); }).find("even slice"),
            std::string::npos);
  HistogramMipmap::StreamBuilder part(s.dims, s.map.size(), 8, 16);
  part.append(std::span(s.ids).subspan(std::size_t(8 * 16 * 12), std::size_t(4 * 16 * 12)));
  EXPECT_NE(error_of([&] { part.finish_part(); }).find("ends at slice 12"), std::string::npos);
  EXPECT_NE(error_of([&] { part.finish(); }).find("slices streamed"), std::string::npos);
}

TEST(StreamedLabels, MipmapBuilderRefusesBrokenStreams) {
  const Extent d{4, 4, 6};
  std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()), 1);
  const std::size_t slice = 16;
  {
    HistogramMipmap::StreamBuilder b(d, 2);
    b.append(std::span(ids).first(3 * slice));  // odd, and not the last slab
    EXPECT_NE(error_of([&] { b.append(std::span(ids).first(3 * slice)); }).find("odd"), std::string::npos);
  }
  {
    HistogramMipmap::StreamBuilder b(d, 2);
    EXPECT_NE(error_of([&] { b.append(std::span(ids).first(slice + 1)); }).find("whole slices"), std::string::npos);
    b.append(std::span(ids).first(4 * slice));
    EXPECT_NE(error_of([&] { b.finish(); }).find("4 slices streamed"), std::string::npos);
  }
  {
    HistogramMipmap::StreamBuilder b(d, 1);  // id 1 is not a source
    EXPECT_NE(error_of([&] { b.append(std::span(ids).first(2 * slice)); }).find("source id 1"), std::string::npos);
  }
}

TEST(StreamedLabels, LabelValuesGatheredBySlabsMatchTheWholeVolume) {
  for (const DType t : {DType::u8, DType::i16, DType::u32, DType::i32}) {
    Volume v = fibres({16, 12, 10}, 30).converted(t);
    const SourceIds whole = to_source_ids(v);
    LabelValueCollector c(t);
    for (std::int64_t z = 0; z < 10; z += 3) c.add(v.crop({{0, 0, z}, {16, 12, std::min<std::int64_t>(10, z + 3)}}));
    const LabelMap map = c.finish();
    EXPECT_EQ(map, whole.map) << dtype_name(t);
    std::vector<std::uint32_t> ids;
    assign_source_ids(v, map, ids);
    EXPECT_EQ(ids, whole.ids) << dtype_name(t);
  }
  EXPECT_THROW(LabelValueCollector(DType::f32), Error);
}

TEST(StreamedLabels, AValueMissingFromTheFirstPassIsAnError) {
  // The input changed between the passes: a value the map does not know must not get an id.
  for (const DType t : {DType::u16, DType::u32}) {
    Volume v({4, 4, 4}, t);
    const LabelMap map(t, {0});
    visit_dtype(t, [&](auto tag) {
      using T = decltype(tag);
      v.samples<T>()[21] = T(7);
    });
    std::vector<std::uint32_t> ids;
    EXPECT_NE(error_of([&] { assign_source_ids(v, map, ids); }).find("value 7 is not among"), std::string::npos)
        << dtype_name(t);
  }
}

TEST(StreamedLabels, ACompactedTableStillInternsToTheSameIds) {
  MixtureTable t(4, true);
  const std::vector<std::uint32_t> ab{0, 1}, bc{1, 2}, ad{0, 3};
  const std::vector<double> even{1, 1}, skew{1, 3};
  const std::uint32_t first = t.intern(ab, even), second = t.intern(bc, skew);
  t.compact();
  EXPECT_EQ(t.intern(ab, even), first);
  EXPECT_EQ(t.intern(bc, skew), second);
  const std::uint32_t third = t.intern(ad, even);
  EXPECT_EQ(third, second + 1);
  EXPECT_EQ(t.intern(ad, even), third);
  EXPECT_EQ(t.mixture(second), SparseMixture::from_sorted({{1, 0.25}, {2, 0.75}}));
}

}  // namespace
}  // namespace strata::mixture
