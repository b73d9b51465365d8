#pragma once
/// @file
/// @brief Writing Neuroglancer precomputed volumes of several scales (a pyramid): the folder
/// format the `precomputed` entry of the format registry reads, and writes with one scale.
///
/// Every scale is unsharded with 64^3 chunks; uint32 and uint64 volumes are written as
/// `segmentation` with the `compressed_segmentation` encoding (8^3 blocks), every other sample
/// type as `image` with the `raw` encoding. Resolutions are stored in nanometres (converted from
/// the geometry's unit; spacing without a unit is taken as nm) and the origin as the scale's
/// `voxel_offset` (origin / resolution, rounded). The format has no direction cosines: they are
/// not written.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

#include "strata/core/volume.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io {

/// @brief Streams the scales of a precomputed volume to `<folder>.tmp`, renamed to `folder` by
/// finish(). Each scale takes its slabs in z order through level(i), scales in any order or
/// interleaved; each holds one chunk row (64 slices) of samples at a time. Destroying the writer
/// before finish() removes the temporary folder. Not thread safe.
class PrecomputedPyramidWriter {
 public:
  /// @brief `levels[0]` is the finest scale; all must share one dtype, which must be one the
  /// format stores (u8, i8, u16, i16, u32, i32, u64, f32), else Error naming the folder. An
  /// existing `folder` is replaced only when it is a precomputed volume (has an `info` file).
  PrecomputedPyramidWriter(std::filesystem::path folder, std::vector<VolumeInfo> levels);
  ~PrecomputedPyramidWriter();
  PrecomputedPyramidWriter(const PrecomputedPyramidWriter&) = delete;
  PrecomputedPyramidWriter& operator=(const PrecomputedPyramidWriter&) = delete;

  /// @brief The writer of scale `level` (< levels.size()): slabs in z order whose x, y and dtype
  /// match the level's. Its own finish() is optional (this finish() ends every scale).
  VolumeWriter& level(std::size_t level);
  /// @brief Writes the `info` file and renames the folder. Throws Error naming a scale that did
  /// not get all its slices.
  void finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief Writes every source of `levels` (finest first) as one scale of the precomputed volume
/// `folder`, reading each slab by slab (a chunk row of 64 slices at a time).
void write_precomputed(const std::filesystem::path& folder, std::span<VolumeSource* const> levels);

}  // namespace strata::io
