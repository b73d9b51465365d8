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
#include <map>
#include <span>
#include <vector>

#include "strata/core/extent.hpp"

namespace strata::mixture {

class FixedRateIds {
 public:
  class Builder;

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
  class Builder;

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

/// @brief Builds a FixedRateIds from consecutive runs of x-fastest ids (e.g. z-slabs), so the
/// whole level never has to be in memory. The id range is given up front: every id appended
/// must lie in [min_id, max_id], and the result equals FixedRateIds(all ids, dims) when min_id
/// and max_id are the ids' true extremes.
class FixedRateIds::Builder {
 public:
  Builder(const Extent& dims, std::uint32_t min_id, std::uint32_t max_id);
  /// @brief Appends the next ids. Throws Error for an id outside the range or past dims.
  void append(std::span<const std::uint32_t> ids);
  /// @brief Appends the ids of `part`, the storage of the next whole slices built with the same
  /// id range (as one MPI rank builds its slices), by copying its packed codes. Throws Error
  /// unless the ids so far fill whole bytes (a multiple of 8) and `part` fits.
  void append_part(const FixedRateIds& part);
  /// @brief The storage; throws Error unless exactly dims.voxel_count() ids were appended.
  FixedRateIds finish();

 private:
  void pack(std::span<const std::uint32_t> ids);  // a multiple of 8 ids: whole bytes
  FixedRateIds out_;
  std::uint64_t count_ = 0;
  std::uint32_t max_ = 0;
  std::vector<std::uint32_t> pending_, codes_;  // < 8 ids not yet packed; scratch
};

/// @brief Builds a BlockPaletteIds from consecutive z-slabs of ids, one 8-slice block row at a
/// time, so the whole level never has to be in memory; the result equals BlockPaletteIds(all
/// ids, dims). Slabs of a multiple of 8 slices are encoded without a copy.
class BlockPaletteIds::Builder {
 public:
  explicit Builder(const Extent& dims);
  /// @brief Appends the next whole slices (x fastest). Throws Error for a partial slice or past dims.z.
  void append(std::span<const std::uint32_t> ids);
  /// @brief Appends the block rows of `part`, the storage of the next slices of the same x-y
  /// extent (as one MPI rank builds its slices): its palettes are deduplicated again against
  /// those so far and its indices copied, so the result equals appending its ids. Throws Error
  /// unless the slices so far are whole block rows and `part` fits (whole block rows unless it
  /// ends the volume).
  void append_part(const BlockPaletteIds& part);
  /// @brief The storage; throws Error unless dims.z slices were appended.
  BlockPaletteIds finish();

 private:
  // One block of a row as encoded in parallel, before its palette is deduplicated.
  struct EncodedBlock {
    std::vector<std::uint32_t> palette;  // ascending
    std::vector<std::byte> indices;      // packed, empty when the palette has one entry
  };
  void encode_block_row(std::span<const std::uint32_t> slices);  // kBlock slices (fewer at the end)
  BlockPaletteIds out_;
  std::vector<EncodedBlock> row_;  // the blocks of the row being encoded (kept for their capacity)
  std::map<std::vector<std::uint32_t>, std::uint32_t> palette_offsets_;  // dedupe identical palettes
  std::vector<std::uint32_t> pending_;  // slices of a block row not yet complete
  std::int64_t slices_ = 0, block_rows_ = 0;
};

}  // namespace strata::mixture
