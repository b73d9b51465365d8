#pragma once
/// @file
/// @brief OME-Zarr output beyond the single-level VolumeWriter: every resolution level of a
/// volume as one multiscale image, the way `strata decompress -o x.ome.zarr` writes a `.strata`
/// file's pyramid.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/io/volume_io.hpp"

namespace strata::io {

/// @brief Writes `levels` (the finest first, each a coarser resolution of the same volume) as an
/// OME-Zarr 0.4 image at the folder `path`: a Zarr v2 group whose arrays "0", "1", ... hold the
/// levels in 64^3 chunks (blosc-zstd, or uncompressed when options.compress is false), and whose
/// `.zattrs` multiscales give each level its scale (the level's spacing) and translation (its
/// geometry's origin) along axes z, y, x of level 0's unit. Each level is read from its source
/// one chunk row (64 slices) at a time. The image is written to `<path>.tmp` and renamed to
/// `path` at the end (replacing what was there); on any error nothing is left behind.
/// Throws ParameterError("levels") when `levels` is empty or the levels differ in sample type.
void write_ome_zarr_pyramid(const std::filesystem::path& path, const std::vector<VolumeSource*>& levels,
                            const WriteOptions& options = {});

/// @brief An OME-Zarr image of `levels` described without a folder: the metadata documents and
/// the chunk bytes write_ome_zarr_pyramid would store, made on demand (the `/zarr/` endpoints of
/// `strata serve` answer with them, so zarr-python, napari and vizarr open a URL). Thread-safe.
class OmeZarrView {
 public:
  /// @brief `name` is the multiscale's name. Throws ParameterError("levels") as
  /// write_ome_zarr_pyramid does.
  OmeZarrView(std::vector<VolumeInfo> levels, const std::string& name, bool compress = true);
  /// @brief `.zgroup` of the image.
  const nlohmann::json& group() const { return group_; }
  /// @brief `.zattrs` of the image (multiscales with each level's scale and translation).
  const nlohmann::json& attributes() const { return attributes_; }
  std::size_t level_count() const { return levels_.size(); }
  /// @brief `.zarray` of level `level` (< level_count()).
  const nlohmann::json& array(std::size_t level) const { return arrays_.at(level); }
  /// @brief The box (level coordinates, clipped to the level) of the chunk whose key is
  /// `<index.z>/<index.y>/<index.x>`; nothing for a level or chunk outside the image.
  std::optional<Box> chunk_box(std::size_t level, const Extent& index) const;
  /// @brief The stored bytes of that chunk from its voxels (`samples`: the chunk's box, the
  /// level's dtype): zero-padded to the whole chunk, compressed as the `.zarray` says. Throws
  /// Error when the samples do not fit the chunk.
  std::vector<std::byte> encode(std::size_t level, const Volume& samples) const;

 private:
  std::vector<VolumeInfo> levels_;
  bool compress_;
  nlohmann::json group_, attributes_;
  std::vector<nlohmann::json> arrays_;
};

}  // namespace strata::io
