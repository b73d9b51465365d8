#pragma once
// The normalised histogram mipmap H of paper §3.1 (Eq. 4). Level 0 holds unit vectors (or,
// for fractional input, the given mixtures); level l averages the 2x2x2 children of level
// l-1 (fewer at odd borders: N = product of the per-axis child counts, each 1 or 2, and
// each level's size is the ceiling of half the previous), down to a 1x1x1 level.
//
// Representation: every level is an array of per-voxel ids into ONE table of distinct
// mixtures shared by all levels (coarse levels repeat mixtures a lot; the factorisation then
// works on distinct mixtures weighted by multiplicity). For single-label input the table is
// integral (exact rationals, see MixtureTable) and level-0 ids are the source ids.
#include <cstdint>
#include <span>
#include <vector>

#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"
#include "strata/mixture/label_map.hpp"
#include "strata/mixture/mixture_table.hpp"

namespace strata::mixture {

// Sizes of levels 0..lmax: each the per-axis ceiling of half the previous, ending at 1x1x1.
std::vector<Extent> mip_level_dims(Extent level0);

struct MipLevel {
  Extent dims;
  std::vector<std::uint32_t> ids;  // x fastest; mixture ids (after factorisation: node ids)

  std::size_t index(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return std::size_t((z * dims.y + y) * dims.x + x);
  }
};

// Level 0 of a fractional segmentation, CSR: voxel v holds entries [offsets[v], offsets[v+1]).
struct FractionalVoxels {
  Extent dims;
  std::uint32_t num_sources = 0;
  std::vector<std::uint64_t> offsets{0};
  std::vector<std::uint32_t> index;
  std::vector<double> weight;
};

struct MipmapStats {
  std::uint64_t voxels = 0;              // all levels
  std::uint64_t distinct_mixtures = 0;   // table entries used
  double nnz_per_voxel = 0.0;            // mean over all voxels of all levels
  std::uint64_t nnz_total = 0;           // mixture entries summed over all voxels of all levels
  std::uint64_t input_pairs = 0;         // sum over distinct mixtures of C(nnz, 2)
  std::uint64_t voxel_pairs = 0;         // sum over voxels of C(nnz, 2)
  std::uint32_t max_nnz = 0;
};

class HistogramMipmap {
 public:
  class StreamBuilder;

  HistogramMipmap() = default;

  // Single-label input given as dense source ids (< num_sources). Exact (integral table).
  static HistogramMipmap from_source_ids(Extent dims, std::vector<std::uint32_t> ids, std::uint32_t num_sources,
                                         ProgressSink& progress = silent_progress());
  // Convenience: to_source_ids + from_source_ids. `map` (optional) receives the label map.
  static HistogramMipmap from_labels(const Volume& labels, LabelMap* map = nullptr,
                                     ProgressSink& progress = silent_progress());
  // Fractional input: each level-0 voxel is already a mixture (weights are l1-normalised
  // per voxel; zero weights dropped). Throws Error on an empty voxel, a negative weight or
  // an index >= num_sources.
  static HistogramMipmap from_fractional(const FractionalVoxels& level0, ProgressSink& progress = silent_progress());

  std::uint32_t num_sources() const { return table_.num_sources(); }
  bool fractional() const { return fractional_; }
  int level_count() const { return int(levels_.size()); }
  int max_level() const { return int(levels_.size()) - 1; }
  // Level 0 of a mipmap from a StreamBuilder has its dims but no ids (they are the source ids).
  const MipLevel& level(int l) const { return levels_.at(std::size_t(l)); }
  const std::vector<MipLevel>& levels() const { return levels_; }
  const MixtureTable& table() const { return table_; }

  std::uint32_t mixture_id(int l, std::int64_t x, std::int64_t y, std::int64_t z) const {
    const auto& L = levels_[std::size_t(l)];
    return L.ids[L.index(x, y, z)];
  }
  // The exact (up to double rounding of mass/total) normalised mixture of a voxel.
  SparseMixture mixture(int l, std::int64_t x, std::int64_t y, std::int64_t z) const {
    return table_.mixture(mixture_id(l, x, y, z));
  }

  MipmapStats stats() const;

  // Moves the per-level arrays out, leaving only the table (level_count() becomes 0); lets
  // factorize() remap them in place to node ids without a second copy of the largest array.
  std::vector<MipLevel> release_levels() { return std::move(levels_); }

 private:
  void build_levels(ProgressSink& progress);  // the levels after the last one held
  // Multiplicities over every level held, plus per source id the counts of a streamed level 0.
  void count_multiplicities(std::span<const std::uint64_t> streamed_level0);

  bool fractional_ = false;
  std::vector<MipLevel> levels_;
  MixtureTable table_;
};

/// @brief Level 1 of a single-label mipmap over level-0 slices [z_begin, z_end) only, as one MPI
/// rank builds it (dist/labels): the mixtures its slices made first, in the order they first
/// occur (ids >= num_sources of a table local to the part), level 1's ids under that table, and
/// the level-0 count of each source id. HistogramMipmap::StreamBuilder::append_part() merges
/// parts in z order into the mipmap of the whole volume.
struct MipmapSlabPart {
  std::int64_t z_begin = 0, z_end = 0;       // level-0 slices
  std::vector<std::uint64_t> offsets{0};     // mixture k: entries [offsets[k], offsets[k+1])
  std::vector<std::uint32_t> index;          // source ids, ascending per mixture
  std::vector<double> mass;                  // canonical integer masses (MixtureTable)
  std::vector<std::uint64_t> first_voxel;    // per mixture: its first level-1 voxel, whole-volume index
  std::vector<std::uint32_t> level1_ids;     // level-1 slices [z_begin/2, ceil(z_end/2)), local ids
  std::vector<std::uint64_t> level0_counts;  // per source id
};

/// @brief Builds a single-label mipmap from level-0 source ids streamed in z-slabs, so level 0
/// (the largest array, one u32 per voxel) is never held: level 1 is built as the slabs arrive
/// and the coarser levels from it at finish(). The result equals from_source_ids() on the whole
/// volume (same table, same ids) except that level(0).ids is empty; level-0 multiplicities are
/// counted as the slabs pass.
///
/// A builder of a slice range (the second constructor) makes one part of level 1 instead
/// (finish_part()); a builder of the whole volume takes such parts in z order (append_part())
/// and gives the same mipmap as if their slabs had been appended.
class HistogramMipmap::StreamBuilder {
 public:
  StreamBuilder(Extent dims, std::uint32_t num_sources);
  /// @brief A builder of level-0 slices [z_begin, z_end) of a volume of `dims`; z_begin even.
  /// Throws Error for an odd or out-of-range start.
  StreamBuilder(Extent dims, std::uint32_t num_sources, std::int64_t z_begin, std::int64_t z_end);
  /// @brief The next whole slices of source ids (x fastest). Every slab but the last must have
  /// an even number of slices (a level-1 slice needs both its children). Throws Error on an id
  /// >= num_sources, a partial slice, too many slices or an odd slab followed by another.
  void append(std::span<const std::uint32_t> ids);
  /// @brief The next slices as a part built elsewhere (same dims and sources; it must start
  /// where the slices so far end). Its new mixtures are interned in their order, so the table
  /// is the one the part's slabs would have made. Throws Error when the part does not fit.
  void append_part(const MipmapSlabPart& part);
  /// @brief How many level-0 voxels hold each source id, over the slices appended so far.
  std::span<const std::uint64_t> level0_counts() const { return level0_counts_; }
  /// @brief Builds the coarser levels (progress task "histogram mipmap"). Throws Error unless
  /// every slice of the volume was appended (and this is not a builder of a slice range).
  HistogramMipmap finish(ProgressSink& progress = silent_progress());
  /// @brief This builder's part of level 1 (consumes it). Throws Error unless every slice of
  /// its range was appended.
  MipmapSlabPart finish_part();

 private:
  std::vector<Extent> dims_;
  HistogramMipmap h_;
  std::vector<std::uint64_t> level0_counts_;
  std::int64_t z_begin_ = 0, z_end_ = 0;  // the range this builder covers
  std::int64_t slices_ = 0;               // next level-0 slice expected
};

}  // namespace strata::mixture
