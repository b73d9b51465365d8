// Camera conventions, framing and the frustum handed to lod.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "strata/core/error.hpp"
#include "strata/render/camera.hpp"

using namespace strata;
using namespace strata::render;

namespace {

constexpr double kPi = std::numbers::pi;

void expect_near(const Vec3& a, const Vec3& b, double tol = 1e-12) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

CameraSpec spec(int w, int h, Projection p, double az, double el) {
  CameraSpec s;
  s.width = w;
  s.height = h;
  s.projection = p;
  s.orbit.azimuth_deg = az;
  s.orbit.elevation_deg = el;
  return s;
}

// Every corner of the volume box.
std::vector<Vec3> corners(const Vec3& size) {
  std::vector<Vec3> out;
  for (int i = 0; i < 8; ++i) out.push_back({i & 1 ? size.x : 0, i & 2 ? size.y : 0, i & 4 ? size.z : 0});
  return out;
}

}  // namespace

TEST(RenderCamera, AzimuthZeroLooksAlongPlusYWithXRightAndZUp) {
  const Camera cam(spec(64, 48, Projection::perspective, 0, 0), {10, 20, 30}, {});
  expect_near(cam.forward(), {0, 1, 0});
  expect_near(cam.right(), {1, 0, 0});
  expect_near(cam.up(), {0, 0, 1});
  expect_near(cam.target(), {5, 10, 15});
  EXPECT_LT(cam.eye().y, 10.0);
}

TEST(RenderCamera, AzimuthAndElevationMoveTheEyeAsDocumented) {
  const Camera cam(spec(64, 48, Projection::perspective, 90, 30), {10, 10, 10}, {});
  // Azimuth 90: the eye is on the +x side; elevation 30: above the target.
  const Vec3 to_eye = normalized(cam.eye() - cam.target());
  expect_near(to_eye, {std::cos(kPi / 6), 0, std::sin(kPi / 6)}, 1e-12);
  expect_near(cam.forward(), -to_eye, 1e-12);
  EXPECT_NEAR(length(cam.eye() - cam.target()), cam.distance(), 1e-9);
  EXPECT_NEAR(dot(cam.right(), cam.up()), 0, 1e-12);
  EXPECT_NEAR(dot(cam.up(), cam.forward()), 0, 1e-12);
  EXPECT_NEAR(length(cam.up()), 1, 1e-12);
}

TEST(RenderCamera, StraightDownStaysWellDefined) {
  const Camera cam(spec(32, 32, Projection::perspective, 0, 90), {8, 8, 8}, {});
  expect_near(cam.forward(), {0, 0, -1}, 1e-12);
  EXPECT_TRUE(std::isfinite(cam.up().x) && std::isfinite(cam.up().y) && std::isfinite(cam.up().z));
  EXPECT_NEAR(length(cam.up()), 1, 1e-12);
}

TEST(RenderCamera, DefaultDistanceFramesTheWholeVolume) {
  // Wide and tall images: the narrower field of view decides.
  for (auto [w, h] : {std::pair{200, 100}, std::pair{100, 200}}) {
    for (Projection p : {Projection::perspective, Projection::orthographic}) {
      const Spacing sp{0.5, 1.0, 2.0};
      const Camera cam(spec(w, h, p, 37, -24), {40, 30, 20}, sp);
      const lod::View view = cam.view();
      for (const Vec3& c : corners({20, 30, 40}))
        for (int i = 0; i < 6; ++i) EXPECT_GE(view.frustum[std::size_t(i)].signed_distance(c), -1e-9) << "plane " << i;
    }
  }
}

TEST(RenderCamera, CentreRayIsTheViewDirection) {
  const Camera cam(spec(64, 48, Projection::perspective, 12, 34), {16, 16, 16}, {});
  const Ray r = cam.ray(31.5, 23.5);  // the image centre lies between the four middle pixels
  expect_near(r.direction, cam.forward(), 1e-12);
  expect_near(r.origin, cam.eye());
}

TEST(RenderCamera, CornerRaysLieOnTheSideFrustumPlanes) {
  for (Projection p : {Projection::perspective, Projection::orthographic}) {
    const Camera cam(spec(64, 48, p, 20, 10), {16, 16, 16}, {});
    const lod::View view = cam.view();
    // Pixel (-0.5, -0.5) is the top-left corner of the image: on the left and top planes.
    const Ray tl = cam.ray(-0.5, -0.5), br = cam.ray(63.5, 47.5);
    for (double t : {1.0, 10.0, 50.0}) {
      const Vec3 a = tl.origin + tl.direction * t, b = br.origin + br.direction * t;
      EXPECT_NEAR(view.frustum[0].signed_distance(a), 0, 1e-9);  // left
      EXPECT_NEAR(view.frustum[3].signed_distance(a), 0, 1e-9);  // top
      EXPECT_NEAR(view.frustum[1].signed_distance(b), 0, 1e-9);  // right
      EXPECT_NEAR(view.frustum[2].signed_distance(b), 0, 1e-9);  // bottom
      EXPECT_GT(view.frustum[1].signed_distance(a), 0);
      EXPECT_GT(view.frustum[2].signed_distance(a), 0);
    }
    // A point just outside the left edge is outside.
    const Ray out = cam.ray(-1.5, 20);
    EXPECT_LT(view.frustum[0].signed_distance(out.origin + out.direction * 20.0), 0);
  }
}

TEST(RenderCamera, PixelSizeMatchesTheRaySpacing) {
  const Camera persp(spec(100, 80, Projection::perspective, 0, 0), {32, 32, 32}, {});
  const lod::View pv = persp.view();
  EXPECT_NEAR(pv.pixel_angle, 30.0 * kPi / 180.0 / 80.0, 1e-15);
  // pixel_angle is the mean angle per pixel (fov / height); at the image centre neighbouring
  // rays are 2 tan(fov/2) / height apart on the plane at unit distance, which exceeds it by
  // the factor 2 tan(fov/2) / fov (2.3% at 30 degrees).
  const Ray a = persp.ray(49.5, 39.5), b = persp.ray(49.5, 40.5);
  const double d = 100, half = 15.0 * kPi / 180.0;
  const double centre_spacing = d * length(a.direction / dot(a.direction, persp.forward()) -
                                           b.direction / dot(b.direction, persp.forward()));
  EXPECT_NEAR(centre_spacing, pv.pixel_size_at(d) * 2 * std::tan(half) / (2 * half), 1e-9);

  CameraSpec s = spec(100, 80, Projection::orthographic, 0, 0);
  s.ortho_height = 40;
  const Camera ortho(s, {32, 32, 32}, {});
  const lod::View ov = ortho.view();
  EXPECT_FALSE(ov.perspective);
  EXPECT_DOUBLE_EQ(ov.pixel_world, 0.5);
  EXPECT_DOUBLE_EQ(ov.pixel_size_at(1), ov.pixel_size_at(1000));
  const Ray c = ortho.ray(10, 10), e = ortho.ray(11, 10);
  EXPECT_NEAR(length(c.origin - e.origin), 0.5, 1e-12);
  expect_near(c.direction, e.direction);
}

TEST(RenderCamera, OrthographicDefaultHeightMatchesThePerspectiveFramingAtTheTarget) {
  const Camera p(spec(64, 64, Projection::perspective, 0, 0), {32, 32, 32}, {});
  const Camera o(spec(64, 64, Projection::orthographic, 0, 0), {32, 32, 32}, {});
  EXPECT_NEAR(o.half_height(), p.distance() * p.half_height(), 1e-9);
}

TEST(RenderCamera, ExplicitTargetAndDistance) {
  CameraSpec s = spec(64, 64, Projection::perspective, 0, 0);
  s.orbit.target = {1, 2, 3};
  s.orbit.target_set = true;
  s.orbit.distance = 10;
  const Camera cam(s, {32, 32, 32}, {});
  expect_near(cam.eye(), {1, -8, 3}, 1e-12);
}

TEST(RenderCamera, RejectsInvalidSpecs) {
  CameraSpec s;
  s.width = 0;
  EXPECT_THROW(Camera(s, {8, 8, 8}, {}), Error);
  s = {};
  s.fov_deg = 180;
  EXPECT_THROW(Camera(s, {8, 8, 8}, {}), Error);
  s = {};
  s.orbit.distance = -1;
  EXPECT_THROW(Camera(s, {8, 8, 8}, {}), Error);
}
