#pragma once
/// @file
/// @brief Picking in the 3D view: the first level-0 voxel along a pixel's ray where the picture
/// becomes solid (RenderSession::pick: a visible label, or half the opacity under the transfer
/// function), found by walking the voxels the ray crosses, front to back.
#include <functional>
#include <optional>

#include "strata/core/extent.hpp"
#include "strata/core/vec3.hpp"
#include "strata/core/volume.hpp"
#include "strata/render/camera.hpp"

namespace strata::render {

/// @brief A voxel a ray reached: which one, where the ray enters it and how far that is.
struct VoxelHit {
  Extent voxel;         ///< level-0 voxel index
  Vec3 point;           ///< world position where the ray enters the voxel (or starts inside it)
  double distance = 0;  ///< world units from the ray's origin to `point`
};

/// @brief Calls `stop(voxel, length)` for the level-0 voxels of a dims x spacing volume (world
/// space of strata/lod/view.hpp: voxel i covers [i, i + 1) x spacing) that `ray` crosses, front
/// to back, with the world length of the ray inside each (Amanatides & Woo's grid walk: every
/// crossed voxel once, none skipped), until `stop` returns true. Returns that voxel, or nothing
/// when the ray misses the volume or leaves it first.
std::optional<VoxelHit> walk_voxels(const Ray& ray, const Extent& dims, const Spacing& spacing,
                                    const std::function<bool(const Extent& voxel, double length)>& stop);

/// @brief What a click in the 3D view picked (RenderSession::pick).
struct Pick {
  VoxelHit hit;
  std::optional<std::int64_t> label;  ///< label files: the label of the voxel
  std::optional<double> value;        ///< scalar and plain files: the voxel's value
};

/// @brief Opacity accumulated along a ray at which a scalar pick stops: where the rendered
/// surface is half formed, so a faint haze in front of an opaque structure is passed through.
constexpr double kPickOpacity = 0.5;

}  // namespace strata::render
