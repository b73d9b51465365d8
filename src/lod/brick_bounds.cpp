#include "strata/lod/brick_bounds.hpp"

#include <algorithm>
#include <cmath>

namespace strata::lod {

WorldBox brick_world_box(const ta::OctreeGeometry& geometry, const Spacing& spacing, const store::BrickKey& key) {
  const Box core = geometry.brick_core_box(key.level, key.x, key.y, key.z);
  const Extent dims0 = geometry.level(0).dims;
  const std::int64_t scale = std::int64_t(1) << key.level;
  auto world = [&](std::int64_t v, std::int64_t limit, double s) { return double(std::min(v * scale, limit)) * s; };
  return {{world(core.lo.x, dims0.x, spacing.x), world(core.lo.y, dims0.y, spacing.y), world(core.lo.z, dims0.z, spacing.z)},
          {world(core.hi.x, dims0.x, spacing.x), world(core.hi.y, dims0.y, spacing.y), world(core.hi.z, dims0.z, spacing.z)}};
}

double voxel_edge(const Spacing& spacing, int level) {
  return std::ldexp(std::max({spacing.x, spacing.y, spacing.z}), level);
}

double near_distance(const View& view) {
  const Plane& near = view.frustum[4];
  if (dot(near.normal, near.normal) == 0) return 0;
  return std::max(0.0, -near.signed_distance(view.eye) / length(near.normal));
}

double view_depth(const View& view, const WorldBox& box) { return view_depth(view, box, near_distance(view)); }

double view_depth(const View& view, const WorldBox& box, double near) {
  // The minimum of a linear function over a box is the sum of per-axis minima.
  double depth = 0;
  for (int a = 0; a < 3; ++a) {
    const double f = view.forward[a], e = view.eye[a];
    depth += std::min(f * (box.lo[a] - e), f * (box.hi[a] - e));
  }
  // A tiny floor keeps pixel_size_at() positive when the frustum has no near plane.
  return std::max({depth, near, 1e-9});
}

bool in_frustum(const View& view, const WorldBox& box) {
  for (const Plane& p : view.frustum) {
    // The corner farthest along the normal: if even it is outside, the whole box is.
    const Vec3 corner{p.normal.x >= 0 ? box.hi.x : box.lo.x, p.normal.y >= 0 ? box.hi.y : box.lo.y,
                      p.normal.z >= 0 ? box.hi.z : box.lo.z};
    if (p.signed_distance(corner) < 0) return false;
  }
  return true;
}

}  // namespace strata::lod
