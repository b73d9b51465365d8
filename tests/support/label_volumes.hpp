#pragma once
// Small segmentations shared by the label tests (normals, lighting, framing).
#include <cstdint>

#include "strata/core/volume.hpp"

namespace strata::test {

/// A cube of n³ u8 voxels holding a ball of `label` (radius `radius` voxels, centre `centre`
/// in voxel units on every axis; voxel centres at i + 0.5) in background 0.
inline Volume label_ball(std::int64_t n, double radius, double centre, std::uint8_t label) {
  Volume v(Extent{n, n, n}, DType::u8);
  auto s = v.view<std::uint8_t>();
  for (std::int64_t z = 0; z < n; ++z)
    for (std::int64_t y = 0; y < n; ++y)
      for (std::int64_t x = 0; x < n; ++x) {
        const double dx = x + 0.5 - centre, dy = y + 0.5 - centre, dz = z + 0.5 - centre;
        s(x, y, z) = dx * dx + dy * dy + dz * dz <= radius * radius ? label : 0;
      }
  return v;
}

}  // namespace strata::test
