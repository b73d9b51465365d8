#pragma once
// Random-access storage of one id per voxel (the Mixture Graph's node ids of one mip level).
// Two layouts:
//  - FixedRateIds: paper Table 1 (A): (id - min) at a fixed bit rate for every voxel.
//  - BlockPaletteIds: the volume is cut into 8^3 blocks; each block stores a palette of the
//    distinct ids it contains and one index per voxel at ceil(log2(palette size)) bits, like
//    compressed_segmentation does for labels. Identical palettes are stored once. Segmentations
//    are locally coherent, so blocks hold few distinct ids and most of the volume costs 0-2 bits.
// Both decode any voxel in O(1) and serialize to a self-describing little-endian byte string.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "strata/core/extent.hpp"

namespace strata::mixture {

class FixedRateIds {
 public:
  FixedRateIds() = default;
  FixedRateIds(std::span<const std::uint32_t> ids, const Extent& dims);  // x-fastest ids

  std::uint32_t at(std::int64_t x, std::int64_t y, std::int64_t z) const;
  const Extent& dims() const { return dims_; }
  int bits() const { return bits_; }
  std::uint32_t min_id() const { return min_; }
  std::size_t byte_size() const { return packed_.size(); }

  std::vector<std::byte> serialize() const;
  static FixedRateIds deserialize(std::span<const std::byte> bytes);  // throws Error on bad input

 private:
  Extent dims_;
  std::uint32_t min_ = 0;
  int bits_ = 0;
  std::vector<std::byte> packed_;
};

class BlockPaletteIds {
 public:
  static constexpr int kBlock = 8;

  BlockPaletteIds() = default;
  BlockPaletteIds(std::span<const std::uint32_t> ids, const Extent& dims);  // x-fastest ids

  std::uint32_t at(std::int64_t x, std::int64_t y, std::int64_t z) const;
  // Every id of `box` (inside dims) into `out` (box.voxel_count() entries), x-fastest, one
  // block header per run of up to 8 voxels. Throws Error when the box or `out` does not fit.
  void decode_box(const Box& box, std::span<std::uint32_t> out) const;
  const Extent& dims() const { return dims_; }
  std::size_t byte_size() const;  // as serialized

  std::vector<std::byte> serialize() const;
  static BlockPaletteIds deserialize(std::span<const std::byte> bytes);  // throws Error on bad input

 private:
  struct BlockHeader {
    std::uint32_t palette_offset = 0;  // into palettes_
    std::uint32_t palette_size = 0;
    std::uint64_t bit_offset = 0;      // into indices_, in bits
    std::uint8_t bits = 0;             // per index; 0 when the palette has one entry
  };
  const BlockHeader& block_of(std::int64_t x, std::int64_t y, std::int64_t z) const;
  std::uint32_t index_in_block(const BlockHeader& b, std::int64_t x, std::int64_t y, std::int64_t z) const;

  // decode_box reads a block row as one 8-byte word, which may run past the last block's
  // indices: indices_ ends with this many zero bytes that are not serialized.
  static constexpr std::size_t kIndexPadding = 8;
  std::size_t index_bytes() const { return indices_.empty() ? 0 : indices_.size() - kIndexPadding; }

  Extent dims_, grid_;
  std::vector<BlockHeader> blocks_;
  std::vector<std::uint32_t> palettes_;
  std::vector<std::byte> indices_;  // packed indices of every block, then kIndexPadding zeros
};

}  // namespace strata::mixture
