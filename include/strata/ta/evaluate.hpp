#pragma once
/// @file
/// @brief Storage cost and reconstruction error of a TA-compressed file against its original
/// (`strata eval`, the demo, and the benchmark tables share this).
#include <cstdint>
#include <vector>

#include "strata/core/metrics.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::ta {

struct StorageReport {
  std::uint64_t file_bytes = 0;
  // Stored bytes by part; entropy-coded bricks attribute their bytes to the parts in proportion.
  std::uint64_t core_bytes = 0, factor_bytes = 0, brick_header_bytes = 0, container_bytes = 0;
  // Error-target files: sparse max-error corrections, and bricks stored losslessly.
  std::uint64_t correction_bytes = 0, lossless_bytes = 0;
  // Masks of the NaN and infinite voxels (payload kind `masked`, without the bricks they wrap).
  std::uint64_t mask_bytes = 0;
  // ta-global: the feature-scale table (its global bases count as factor bytes).
  std::uint64_t feature_scale_bytes = 0;
  std::vector<std::int64_t> bricks_per_level, constant_per_level;
  std::vector<std::uint64_t> payload_bytes_per_level;  // stored brick payloads (as in the file) per level
  double bits_per_voxel(std::uint64_t bytes, const VolumeInfo& source) const;
};

StorageReport storage_report(const TaVolume& volume);

struct ErrorReport {
  int rank = 0;
  ErrorMetrics metrics;
  double decode_seconds = 0;  // level 0, all bricks, on thread_count() threads
  // Levels 1.. against the original box-filtered to them (2x2x2 means level by level, the odd
  // last column, row or slice standing for itself, as the compressor builds its pyramid; NaN
  // and infinity ignored where a cell has finite voxels): what a coarse level costs in accuracy
  // besides the resolution it gave up.
  std::vector<ErrorMetrics> coarse;
};

// Decodes level 0 at rank K a few brick rows at a time and compares with `original`; with
// `coarse_levels` also every coarser level (ErrorReport::coarse), from one more pass over the
// original in slabs aligned to the coarsest level.
ErrorReport error_report(const TaVolume& volume, io::VolumeSource& original, int k, bool coarse_levels = false);

}  // namespace strata::ta
