#pragma once
/// @file
/// @brief Where a brick lies in world space (view.hpp) and how it relates to a view: the geometric
/// tests behind the level-of-detail cut.
#include "strata/core/vec3.hpp"
#include "strata/core/volume.hpp"
#include "strata/lod/view.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/octree.hpp"

namespace strata::lod {

/// @brief An axis-aligned box in world coordinates (voxel position times spacing).
struct WorldBox {
  Vec3 lo, hi;
};

/// @brief The world box of the brick's core voxels (the region it is drawn for), clipped to the volume
/// box [0, dims * spacing]: a coarse level's last voxel may reach past the level-0 border.
WorldBox brick_world_box(const ta::OctreeGeometry& geometry, const Spacing& spacing, const store::BrickKey& key);

/// @brief World edge of one voxel of `level` (the largest of the three axes, so anisotropic volumes
/// are refined by their coarsest axis).
double voxel_edge(const Spacing& spacing, int level);

/// @brief The near plane's distance from the eye along the view direction (0 when the frustum has no
/// usable near plane).
double near_distance(const View& view);

/// @brief Smallest depth along view.forward of a point of `box`, measured from view.eye and clamped to
/// the near plane (points nearer than it are never drawn; the clamp also keeps a perspective
/// pixel size positive for boxes around the eye).
double view_depth(const View& view, const WorldBox& box);
/// @brief The same with near_distance(view) computed once by the caller (per frame, not per brick).
double view_depth(const View& view, const WorldBox& box, double near);

/// @brief False when the box lies wholly outside one of the frustum planes. Planes with a zero normal
/// (an unset frustum) never cull.
bool in_frustum(const View& view, const WorldBox& box);

}  // namespace strata::lod
