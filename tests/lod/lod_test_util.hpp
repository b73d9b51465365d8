#pragma once
// Helpers shared by the lod tests: small compressed volumes and hand-built views (the render
// camera is not a dependency of lod).
#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>

#include "strata/lod/brick_bounds.hpp"
#include "strata/lod/view.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/ta_volume.hpp"
#include "support/test_support.hpp"
#include "ta/ta_test_util.hpp"

namespace strata::lod::testing {

inline constexpr std::uint64_t kAllBins = ~std::uint64_t(0);

// A 64^3 prisms volume in 16-wide bricks (core 12): 4 levels with 216, 27, 8 and 1 bricks.
// Compressed once per test program by codec `*Codec`; rank 8 of stored 8.
template <const char* const* Codec>
class PrismsVolume {
 public:
  static const ta::TaVolume& volume() {
    static PrismsVolume instance;
    return *instance.volume_;
  }

 private:
  PrismsVolume() {
    const auto path = dir_ / "prisms64.strata";
    ta::CompressParams params = ta::testing::params(16, 2, 8, "u16,b8log+");
    params.codec_name = *Codec;
    ta::testing::compress(ta::testing::prisms({64, 64, 64}, 11), path, params);
    volume_ = std::make_unique<ta::TaVolume>(path);
  }
  test::TempDir dir_;
  std::unique_ptr<ta::TaVolume> volume_;
};

// The per-brick codec (ta-bricked).
inline constexpr const char* kBricked = ta::kBrickedCodecName;
inline constexpr const char* kGlobal = ta::kGlobalCodecName;
using Prisms64 = PrismsVolume<&kBricked>;

// A perspective view from `eye` towards `target` (up = +y unless parallel), square image of
// `pixels` rows, vertical field of view `fov_deg`.
inline View perspective_view(const Vec3& eye, const Vec3& target, int pixels = 64, double fov_deg = 30,
                             double near = 0.1, double far = 1e6) {
  View v;
  v.eye = eye;
  v.forward = normalized(target - eye);
  const Vec3 up0 = std::abs(v.forward.y) > 0.99 ? Vec3{0, 0, 1} : Vec3{0, 1, 0};
  const Vec3 right = normalized(cross(v.forward, up0));
  const Vec3 up = cross(right, v.forward);
  const double t = std::tan(fov_deg * std::numbers::pi / 360);
  auto plane = [&](const Vec3& n) { return Plane{n, -dot(n, eye)}; };
  v.frustum[0] = plane(right + v.forward * t);    // left: x >= -t z
  v.frustum[1] = plane(-right + v.forward * t);   // right
  v.frustum[2] = plane(up + v.forward * t);       // bottom
  v.frustum[3] = plane(-up + v.forward * t);      // top
  v.frustum[4] = {v.forward, -dot(v.forward, eye) - near};
  v.frustum[5] = {-v.forward, dot(v.forward, eye) + far};
  v.perspective = true;
  v.pixel_angle = fov_deg * std::numbers::pi / 180 / pixels;
  return v;
}

inline Vec3 centre_of(const ta::TaVolume& t) {
  const Extent d = t.source_info().dims;
  const Spacing s = t.source_info().spacing;
  return {d.x * s.x / 2, d.y * s.y / 2, d.z * s.z / 2};
}

// Looking at the volume centre along -z from `distance` away, 60 degree field of view: from
// 110 voxels on, all of a 64^3 volume is in view.
inline View view_from(const ta::TaVolume& t, double distance, int pixels = 128) {
  const Vec3 c = centre_of(t);
  return perspective_view(c + Vec3{0, 0, distance}, c, pixels, 60);
}

}  // namespace strata::lod::testing
