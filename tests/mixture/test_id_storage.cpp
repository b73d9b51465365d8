#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/mixture/id_storage.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::mixture;

namespace {

// Locally coherent ids: a few regions per 8^3 block, as segmentations have.
std::vector<std::uint32_t> coherent_ids(const Extent& d, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()));
  const std::uint32_t base = 1000 + rng() % 1000;
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x)
        ids[std::size_t((z * d.y + y) * d.x + x)] = base + std::uint32_t((x / 13 + 3 * (y / 11) + 11 * (z / 9)) % 37);
  return ids;
}

template <class Storage>
void expect_all_equal(const Storage& s, const std::vector<std::uint32_t>& ids, const Extent& d) {
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x)
        ASSERT_EQ(s.at(x, y, z), ids[std::size_t((z * d.y + y) * d.x + x)]) << x << "," << y << "," << z;
}

}  // namespace

TEST(MixtureIdStorage, FixedRateRoundTripsAndUsesMinimalBits) {
  const Extent d{40, 30, 20};
  auto ids = coherent_ids(d, 1);
  FixedRateIds f(ids, d);
  EXPECT_EQ(f.bits(), 5);  // ids span 0..3+3*2+11*2 = 31 above the minimum -> 32 values -> 5 bits
  expect_all_equal(f, ids, d);
  FixedRateIds g = FixedRateIds::deserialize(f.serialize());
  expect_all_equal(g, ids, d);
  std::vector<std::uint32_t> constant(std::size_t(d.voxel_count()), 42);
  FixedRateIds c(constant, d);
  EXPECT_EQ(c.bits(), 0);
  EXPECT_EQ(c.at(12, 8, 6), 42u);
}

TEST(MixtureIdStorage, BlockPaletteRoundTripsOnOddSizes) {
  const Extent d{21, 17, 10};  // edge blocks are partial on every axis
  auto ids = coherent_ids(d, 2);
  BlockPaletteIds b(ids, d);
  expect_all_equal(b, ids, d);
  BlockPaletteIds c = BlockPaletteIds::deserialize(b.serialize());
  expect_all_equal(c, ids, d);
  EXPECT_EQ(b.serialize().size(), b.byte_size());
  const Box box{{3, 5, 2}, {19, 16, 9}};
  std::vector<std::uint32_t> part(std::size_t(box.voxel_count()));
  c.decode_box(box, part);
  std::size_t i = 0;
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
      for (std::int64_t x = box.lo.x; x < box.hi.x; ++x) ASSERT_EQ(part[i++], ids[std::size_t((z * d.y + y) * d.x + x)]);
  std::vector<std::uint32_t> short_out(part.size() - 1);
  EXPECT_NE(test::error_of([&] { c.decode_box(box, short_out); }).find("outputs for"), std::string::npos);
}

TEST(MixtureIdStorage, BlockPaletteIsSmallForCoherentIdsAndSharesPalettes) {
  const Extent d{64, 64, 64};
  auto ids = coherent_ids(d, 3);
  BlockPaletteIds b(ids, d);
  FixedRateIds f(ids, d);
  // Few ids per block: far below the fixed rate of 6 bits per voxel.
  EXPECT_LT(8.0 * double(b.byte_size()) / double(d.voxel_count()), 0.6 * 8.0 * double(f.byte_size()) / double(d.voxel_count()));
  // A uniform volume needs no index bits and one palette entry in total.
  std::vector<std::uint32_t> uniform(std::size_t(d.voxel_count()), 7);
  BlockPaletteIds u(uniform, d);
  EXPECT_LT(u.byte_size(), std::size_t(512 * 17 + 200));
  EXPECT_EQ(u.at(63, 0, 31), 7u);
}

TEST(MixtureIdStorage, CorruptStreamsAreErrors) {
  const Extent d{16, 16, 16};
  auto ids = coherent_ids(d, 4);
  auto bytes = BlockPaletteIds(ids, d).serialize();
  EXPECT_THROW(BlockPaletteIds::deserialize(std::span(bytes).first(bytes.size() - 1)), Error);
  auto bad = bytes;
  bad[0] = std::byte{9};
  EXPECT_THROW(BlockPaletteIds::deserialize(bad), Error);
  // Point a block's palette past the palette table.
  auto wrong = bytes;
  const std::size_t first_header = 1 + 24 + 24;
  std::uint32_t huge = 1u << 30;
  std::memcpy(wrong.data() + first_header, &huge, 4);
  EXPECT_THROW(BlockPaletteIds::deserialize(wrong), Error);
  auto fixed = FixedRateIds(ids, d).serialize();
  EXPECT_THROW(FixedRateIds::deserialize(std::span(fixed).first(fixed.size() - 3)), Error);
}

// decode_box reads a block row at once for 1..8-bit indices and per voxel above: blocks with
// 1 to 512 distinct ids (index widths 0..9), boxes at random offsets, against the ids and at().
TEST(MixtureIdStorage, BlockPaletteDecodesEveryIndexWidth) {
  const Extent d{40, 24, 24};  // 5 x 3 x 3 blocks
  std::mt19937 rng(11);
  std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()));
  const std::uint32_t distinct[] = {1, 2, 3, 4, 5, 8, 9, 16, 17, 31, 64, 65, 100, 128, 129, 200, 255,
                                    256, 257, 300, 400, 511, 512, 7, 33, 6, 70, 140, 250, 384, 2, 1, 90, 480, 12, 3, 260,
                                    45, 13, 500, 240, 22, 1, 150, 96};
  static_assert(std::size(distinct) == 45);  // one per block
  for (std::int64_t bz = 0; bz < 3; ++bz)
    for (std::int64_t by = 0; by < 3; ++by)
      for (std::int64_t bx = 0; bx < 5; ++bx) {
        const std::uint32_t n = distinct[std::size_t((bz * 3 + by) * 5 + bx)];
        std::vector<std::uint32_t> local(512);
        for (std::uint32_t v = 0; v < 512; ++v) local[v] = 70000 + 3 * (v % n);  // every one of the n ids occurs
        std::shuffle(local.begin(), local.end(), rng);
        for (std::int64_t k = 0; k < 8; ++k)
          for (std::int64_t j = 0; j < 8; ++j)
            for (std::int64_t i = 0; i < 8; ++i)
              ids[std::size_t(((bz * 8 + k) * d.y + by * 8 + j) * d.x + bx * 8 + i)] = local[std::size_t((k * 8 + j) * 8 + i)];
      }
  const BlockPaletteIds b = BlockPaletteIds::deserialize(BlockPaletteIds(ids, d).serialize());
  expect_all_equal(b, ids, d);
  for (int round = 0; round < 200; ++round) {
    auto pick = [&](std::int64_t n) { return std::int64_t(rng() % std::uint32_t(n)); };
    Extent lo{pick(d.x), pick(d.y), pick(d.z)};
    Extent hi{lo.x + 1 + pick(d.x - lo.x), lo.y + 1 + pick(d.y - lo.y), lo.z + 1 + pick(d.z - lo.z)};
    const Box box{lo, hi};
    std::vector<std::uint32_t> out(std::size_t(box.voxel_count()));
    b.decode_box(box, out);
    std::size_t i = 0;
    for (std::int64_t z = lo.z; z < hi.z; ++z)
      for (std::int64_t y = lo.y; y < hi.y; ++y)
        for (std::int64_t x = lo.x; x < hi.x; ++x)
          ASSERT_EQ(out[i++], ids[std::size_t((z * d.y + y) * d.x + x)]) << box.to_string() << " at " << x << "," << y << "," << z;
  }
}

TEST(MixtureIdStorage, BuildersFedInPiecesEqualTheWholeConstruction) {
  const Extent d{21, 17, 29};  // partial blocks on every axis; 29 slices = 3 block rows + 5
  const auto ids = coherent_ids(d, 4);
  const std::size_t slice = std::size_t(d.x * d.y);
  const auto whole_blocks = BlockPaletteIds(ids, d).serialize();
  for (const std::vector<std::size_t>& pieces :
       std::vector<std::vector<std::size_t>>{{29}, {8, 8, 8, 5}, {3, 5, 11, 1, 9}, {1, 27, 1}}) {
    BlockPaletteIds::Builder b(d);
    std::size_t at = 0;
    for (const std::size_t slices : pieces) {
      b.append(std::span(ids).subspan(at, slices * slice));
      at += slices * slice;
    }
    EXPECT_EQ(b.finish().serialize(), whole_blocks) << pieces.size() << " pieces";
  }
  const auto [lo, hi] = std::minmax_element(ids.begin(), ids.end());
  const auto whole_fixed = FixedRateIds(ids, d).serialize();
  for (const std::size_t run : {std::size_t(1), std::size_t(7), std::size_t(13), ids.size()}) {
    FixedRateIds::Builder b(d, *lo, *hi);
    for (std::size_t at = 0; at < ids.size(); at += run) b.append(std::span(ids).subspan(at, std::min(run, ids.size() - at)));
    EXPECT_EQ(b.finish().serialize(), whole_fixed) << "runs of " << run;
  }
}

TEST(MixtureIdStorage, BlockPalettesAreTheSameBytesOnAnyNumberOfThreads) {
  const Extent d{77, 45, 19};  // many blocks per row, partial blocks on every axis
  const auto ids = coherent_ids(d, 6);
  set_thread_count(1);
  const auto one = BlockPaletteIds(ids, d).serialize();
  for (const int threads : {2, 3, 8}) {
    set_thread_count(threads);
    EXPECT_EQ(BlockPaletteIds(ids, d).serialize(), one) << threads << " threads";
  }
  set_thread_count(0);
  const BlockPaletteIds decoded = BlockPaletteIds::deserialize(one);
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x)
        ASSERT_EQ(decoded.at(x, y, z), ids[std::size_t((z * d.y + y) * d.x + x)]) << x << "," << y << "," << z;
}

TEST(MixtureIdStorage, PartsBuiltApartMergeToTheWholeStorage) {
  const Extent d{21, 17, 29};  // partial blocks in x and y; the last part ends the volume mid block row
  const auto ids = coherent_ids(d, 4);
  const std::size_t slice = std::size_t(d.x * d.y);
  const auto [lo, hi] = std::minmax_element(ids.begin(), ids.end());
  auto piece = [&](std::int64_t z0, std::int64_t z1) {
    return std::span(ids).subspan(std::size_t(z0) * slice, std::size_t(z1 - z0) * slice);
  };
  const std::int64_t cuts[] = {0, 8, 24, 29};
  BlockPaletteIds::Builder blocks(d);
  FixedRateIds::Builder fixed(d, *lo, *hi);
  for (int k = 0; k < 3; ++k) {
    const Extent part{d.x, d.y, cuts[k + 1] - cuts[k]};
    if (k == 1) {  // a part streamed in between parts merged
      blocks.append(piece(cuts[k], cuts[k + 1]));
      fixed.append(piece(cuts[k], cuts[k + 1]));
      continue;
    }
    // Through bytes, as the parts travel between ranks.
    blocks.append_part(BlockPaletteIds::deserialize(BlockPaletteIds(piece(cuts[k], cuts[k + 1]), part).serialize()));
    FixedRateIds::Builder f(part, *lo, *hi);
    f.append(piece(cuts[k], cuts[k + 1]));
    fixed.append_part(FixedRateIds::deserialize(f.finish().serialize()));
  }
  EXPECT_EQ(blocks.finish().serialize(), BlockPaletteIds(ids, d).serialize());
  EXPECT_EQ(fixed.finish().serialize(), FixedRateIds(ids, d).serialize());
}

TEST(MixtureIdStorage, PartsThatDoNotContinueAreRefused) {
  const Extent d{9, 9, 24};
  const auto ids = coherent_ids(d, 3);
  const std::size_t slice = 81;
  const auto rows = BlockPaletteIds(std::span(ids).first(8 * slice), {9, 9, 8});
  BlockPaletteIds::Builder blocks(d);
  blocks.append(std::span(ids).first(3 * slice));  // not a whole block row
  EXPECT_THROW(blocks.append_part(rows), Error);
  BlockPaletteIds::Builder other(d);
  const auto flat = BlockPaletteIds(std::span(ids).first(8 * slice), {81, 1, 8});
  EXPECT_THROW(other.append_part(flat), Error);  // x-y extents differ
  const auto partial = BlockPaletteIds(std::span(ids).first(3 * slice), {9, 9, 3});
  EXPECT_THROW(other.append_part(partial), Error);  // not whole block rows, and not the end
  const auto [lo, hi] = std::minmax_element(ids.begin(), ids.end());
  FixedRateIds::Builder fixed(d, *lo, *hi);
  FixedRateIds::Builder wider({9, 9, 8}, *lo, *hi + 1000);  // another bit rate
  wider.append(std::span(ids).first(8 * slice));
  EXPECT_THROW(fixed.append_part(wider.finish()), Error);
  fixed.append(std::span(ids).first(3));  // ids so far do not fill whole bytes
  FixedRateIds::Builder same({9, 9, 8}, *lo, *hi);
  same.append(std::span(ids).first(8 * slice));
  EXPECT_THROW(fixed.append_part(same.finish()), Error);
}

TEST(MixtureIdStorage, BuildersRefuseWrongCountsAndRanges) {
  const Extent d{9, 9, 9};
  const std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()), 5);
  BlockPaletteIds::Builder blocks(d);
  EXPECT_THROW(blocks.append(std::span(ids).first(10)), Error);  // not whole slices
  blocks.append(std::span(ids).first(81 * 4));
  EXPECT_THROW(blocks.finish(), Error);  // 4 of 9 slices
  FixedRateIds::Builder fixed(d, 0, 4);
  EXPECT_THROW(fixed.append(ids), Error);  // 5 is outside [0, 4]
  FixedRateIds::Builder short_of(d, 5, 5);
  short_of.append(std::span(ids).first(100));
  EXPECT_THROW(short_of.finish(), Error);
}
