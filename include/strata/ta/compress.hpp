#pragma once
// `strata compress`: streams a volume into a bricked TA octree inside a .strata container.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "strata/core/progress.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/brick_codec.hpp"
#include "strata/ta/global_basis.hpp"
#include "strata/ta/octree.hpp"

namespace strata::ta {

/// @brief What `compress` writes and how (validate(const CompressParams&) in
/// ta/codec_registry.hpp checks it).
struct CompressParams {
  BrickLayout layout;
  CodecParams codec;
  /// The registered codec (ta/codec_registry.hpp) that writes the file: per-brick bases (paper
  /// 1, the default) or one set of global bases with per-brick cores (paper 2, kGlobalCodecName;
  /// fixed rank only, no NaN yet), or any codec registered since.
  std::string codec_name{kBrickedCodecName};
  /// ta-global: the global fit. Its rank is codec.rank and its slab size that of the input slabs.
  GlobalFitOptions global;
  // Bound on the compressor's working memory in bytes (0 = none: 64 MiB input slabs). The
  // per-level brick-row windows are fixed by the volume's x*y extent; the input slab size
  // shrinks to fit the rest. Throws Error if even one-slice slabs cannot fit.
  std::uint64_t memory_limit = 0;
};

// Bytes the compressor holds regardless of the slab size: for each level, the slices of one
// brick row plus its overlap and the decoded row handed to the next level, in float; with
// `feature_reference` (ta-global) also the coarse levels' feature-scale reference (two floats
// per voxel over the same slices).
std::uint64_t fixed_working_set(const OctreeGeometry& geometry, bool feature_reference = false);
// Input slab size (bytes of the source type) that keeps the total within params.memory_limit.
std::uint64_t input_slab_bytes(const OctreeGeometry& geometry, const VolumeInfo& source, const CompressParams& params);

struct LevelCounts {
  std::int64_t bricks = 0, constant = 0;
  std::int64_t hosvd_trials = 0;   // error-target mode: bricks coded in both bases (the rest only in the block DCT)
  double rmse = 0, max_error = 0;  // error-target mode: measured over the level's voxels
};

struct CompressReport {
  std::vector<LevelCounts> levels;
  std::uint64_t file_bytes = 0, core_bytes = 0, factor_bytes = 0, brick_header_bytes = 0, container_bytes = 0;
  double seconds = 0, prepass_seconds = 0;
  std::uint64_t input_voxels = 0;
  int attempts = 1;  // encoding passes (a PSNR/RMSE budget the calibrated step missed takes another)
  std::vector<double> global_fit;  // ta-global: the global model's fit after each sweep
  double global_seconds = 0;       // ta-global: time of the global fit
};

/// @brief The rank `strata compress` stores when none is given: half the brick width in
/// fixed-rank mode; with an error target the brick width, the cap each brick's ranks stay under.
int default_rank(const BrickLayout& layout, TargetKind target);

/// @brief The ranks of the ta-global feature-scale table for bases of `rank` columns: every
/// ⌈rank / 4⌉-th rank up to `rank` (4, 8, 12, 16 for rank 16).
std::vector<int> feature_scale_ladder(int rank);

// Reads `source` slab by slab (twice: a first pass for the value range that the per-brick
// histograms need, then the encoding pass); only the slices one brick row needs are held per
// level. Output goes to `<out>.tmp`, renamed when complete.
CompressReport compress_volume(io::VolumeSource& source, const std::filesystem::path& out,
                               const CompressParams& params, ProgressSink& progress);

}  // namespace strata::ta
