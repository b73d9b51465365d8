// The grid walk behind picking (strata/render/pick.hpp).
#include "strata/render/pick.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "render/traversal.hpp"

namespace strata::render {

std::optional<VoxelHit> walk_voxels(const Ray& ray, const Extent& dims, const Spacing& spacing,
                                    const std::function<bool(const Extent& voxel, double length)>& stop) {
  const std::array<double, 3> cell{spacing.x, spacing.y, spacing.z};
  const std::array<std::int64_t, 3> n{dims.x, dims.y, dims.z};
  const std::array<double, 3> size{cell[0] * double(n[0]), cell[1] * double(n[1]), cell[2] * double(n[2])};
  auto [t, t_exit] = detail::clip_to_box(ray.origin, ray.direction, Vec3{size[0], size[1], size[2]},
                                        detail::DividedByDirection<Vec3>{ray.direction});
  if (!(t < t_exit)) return std::nullopt;
  // The voxel the ray enters first (its entry point may sit on the far face by rounding).
  std::array<std::int64_t, 3> v{};
  std::array<std::int64_t, 3> step{};
  std::array<double, 3> t_next{}, t_delta{};
  for (int a = 0; a < 3; ++a) {
    const std::size_t i = std::size_t(a);
    const double d = ray.direction[a];
    const double p = ray.origin[a] + d * t;
    v[i] = std::clamp(std::int64_t(std::floor(p / cell[i])), std::int64_t(0), n[i] - 1);
    if (d > 0) {
      step[i] = 1;
      t_next[i] = (double(v[i] + 1) * cell[i] - ray.origin[a]) / d;
      t_delta[i] = cell[i] / d;
    } else if (d < 0) {
      step[i] = -1;
      t_next[i] = (double(v[i]) * cell[i] - ray.origin[a]) / d;
      t_delta[i] = -cell[i] / d;
    } else {
      t_next[i] = t_delta[i] = std::numeric_limits<double>::infinity();
    }
  }
  while (t < t_exit) {
    const int a = t_next[0] <= t_next[1] ? (t_next[0] <= t_next[2] ? 0 : 2) : (t_next[1] <= t_next[2] ? 1 : 2);
    const std::size_t i = std::size_t(a);
    const double t_out = std::min(t_next[i], t_exit);
    const Extent voxel{v[0], v[1], v[2]};
    if (stop(voxel, std::max(0.0, t_out - t))) return VoxelHit{voxel, ray.origin + ray.direction * t, t};
    t = t_out;
    v[i] += step[i];
    t_next[i] += t_delta[i];
    if (v[i] < 0 || v[i] >= n[i]) break;
  }
  return std::nullopt;
}

}  // namespace strata::render
