#pragma once
/// @file
/// @brief Writing Neuroglancer precomputed volumes of several scales (a pyramid): the folder
/// format the `precomputed` entry of the format registry reads, and writes with one scale.
///
/// Every scale is unsharded with 64^3 chunks; uint32 and uint64 volumes are written as
/// `segmentation` with the `compressed_segmentation` encoding (8^3 blocks), every other sample
/// type as `image` with the `raw` encoding (uint8 images as `jpeg` when PrecomputedEncoding asks). Resolutions are stored in nanometres (converted from
/// the geometry's unit; spacing without a unit is taken as nm) and the origin as the scale's
/// `voxel_offset` (origin / resolution, rounded). The format has no direction cosines: they are
/// not written.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/core/volume.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io {

/// @brief How image scales are encoded; segmentations are always compressed_segmentation.
struct PrecomputedEncoding {
  /// 1..100: uint8 images as `jpeg` chunks of this quality (lossy and several times smaller, what
  /// Neuroglancer's EM volumes use); 0: `raw`. Other sample types stay `raw`: the format's jpeg
  /// holds 8-bit samples only. Another value is a ParameterError.
  int jpeg_quality = 0;
};

/// @brief Streams the scales of a precomputed volume to `<folder>.tmp`, renamed to `folder` by
/// finish(). Each scale takes its slabs in z order through level(i), scales in any order or
/// interleaved; each holds one chunk row (64 slices) of samples at a time. Destroying the writer
/// before finish() removes the temporary folder. Not thread safe.
class PrecomputedPyramidWriter {
 public:
  /// @brief `levels[0]` is the finest scale; all must share one dtype, which must be one the
  /// format stores (u8, i8, u16, i16, u32, i32, u64, f32), else Error naming the folder. An
  /// existing `folder` is replaced only when it is a precomputed volume (has an `info` file).
  PrecomputedPyramidWriter(std::filesystem::path folder, std::vector<VolumeInfo> levels,
                           const PrecomputedEncoding& encoding = {});
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

/// @brief A precomputed volume of `levels` described without a folder: the `info` and the chunk
/// bytes the pyramid writer would store, made on demand (the `/precomputed/` endpoints of
/// `strata serve` answer with them). Thread-safe (const).
class PrecomputedView {
 public:
  /// @brief A chunk of one scale: the level and the box it covers, in level coordinates.
  struct Chunk {
    std::size_t level = 0;
    Box box;
  };
  /// @brief Throws Error naming `name` as PrecomputedPyramidWriter does for `levels`.
  PrecomputedView(std::vector<VolumeInfo> levels, const std::string& name, const PrecomputedEncoding& encoding = {});
  ~PrecomputedView();
  /// @brief The `info` JSON.
  const nlohmann::json& info() const { return info_; }
  /// @brief The chunk a request path names: `key` a scale's key, `name` the canonical
  /// `<x0>-<x1>_<y0>-<y1>_<z0>-<z1>` of a chunk of its grid (voxel space, clipped to the
  /// scale). Nothing for anything else (unknown key, misaligned, outside, malformed).
  std::optional<Chunk> chunk(std::string_view key, std::string_view name) const;
  /// @brief The stored bytes of a chunk from its voxels (`samples`: the chunk's box, the
  /// level's dtype): raw (or jpeg), or compressed_segmentation for u32/u64. Throws Error when the
  /// samples do not fit the chunk.
  std::vector<std::byte> encode(const Chunk& chunk, const Volume& samples) const;

 private:
  struct Scales;
  std::unique_ptr<const Scales> scales_;
  nlohmann::json info_;
};

}  // namespace strata::io
