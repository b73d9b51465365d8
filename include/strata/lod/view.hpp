#pragma once
/// @file
/// @brief What the level-of-detail selection needs to know about a camera, without depending on the
/// renderer: the eye, the view frustum and how large one pixel is at a given distance.
///
/// World space (shared by lod and render): level-0 voxel coordinates times the volume spacing.
/// Voxel i of level 0 covers [i, i+1) along each axis (centre i + 0.5), so the volume occupies
/// the box [0, dims * spacing]. Voxel j of level l covers [j 2^l, (j+1) 2^l) in level-0 units.
#include <array>

#include "strata/core/vec3.hpp"

namespace strata::lod {

/// @brief Points p with dot(normal, p) + offset >= 0 are on the inner side.
struct Plane {
  Vec3 normal;
  double offset = 0;
  double signed_distance(const Vec3& p) const { return dot(normal, p) + offset; }
};

/// @brief A camera as the selection sees it (render::Camera::view() makes one).
struct View {
  Vec3 eye;                    // perspective: centre of projection; orthographic: a point on the image plane
  Vec3 forward{0, 0, -1};      // unit viewing direction
  std::array<Plane, 6> frustum{};  // left, right, bottom, top, near, far
  bool perspective = true;
  double pixel_angle = 0;      // perspective: vertical field of view / image height (radians per pixel)
  double pixel_world = 0;      // orthographic: world units per pixel

  /// @brief World-space edge length covered by one pixel at `distance` along the view direction.
  double pixel_size_at(double distance) const { return perspective ? distance * pixel_angle : pixel_world; }
};

}  // namespace strata::lod
