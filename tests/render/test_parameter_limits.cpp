// Values that reach the renderer from users: non-finite or out-of-range camera, sampling and
// session values are refused with a ParameterError naming the struct field (they crashed or hung
// the ray casters before).
#include <gtest/gtest.h>

#include <limits>

#include "strata/core/error.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/label_raycaster.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/render_session.hpp"
#include "strata/render/sampling_limits.hpp"
#include "support/test_support.hpp"

namespace strata::render {
namespace {

using test::parameter_of;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string camera_error(void (*change)(CameraSpec&)) {
  CameraSpec s;
  change(s);
  return parameter_of([&] { Camera(s, {8, 8, 8}, {}); });
}

TEST(RenderParameterLimits, CameraRefusesNonFiniteAngles) {
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.orbit.azimuth_deg = kInf; }), "OrbitParams::azimuth_deg");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.orbit.azimuth_deg = kNaN; }), "OrbitParams::azimuth_deg");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.orbit.azimuth_deg = 1e300; }), "OrbitParams::azimuth_deg");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.orbit.elevation_deg = kInf; }), "OrbitParams::elevation_deg");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.orbit.elevation_deg = 90.5; }), "OrbitParams::elevation_deg");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.orbit.distance = kInf; }), "OrbitParams::distance");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.orbit.distance = kNaN; }), "OrbitParams::distance");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.fov_deg = kNaN; }), "CameraSpec::fov_deg");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.ortho_height = kInf; }), "CameraSpec::ortho_height");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.width = kMaxImageEdge + 1; }), "CameraSpec::width");
  EXPECT_EQ(camera_error([](CameraSpec& s) { s.height = 0; }), "CameraSpec::height");
  EXPECT_EQ(camera_error([](CameraSpec& s) {
              s.orbit.target = {kNaN, 0, 0};
              s.orbit.target_set = true;
            }),
            "OrbitParams::target");
  // The limits themselves are fine.
  EXPECT_EQ(camera_error([](CameraSpec& s) {
              s.orbit.azimuth_deg = -kMaxAzimuthDeg;
              s.orbit.elevation_deg = -90;
              s.orbit.distance = kMaxDistance;
            }),
            "");
}

TEST(RenderParameterLimits, StepsAreBounded) {
  EXPECT_EQ(parameter_of([] { check_step(1e-9, "x"); }), "x");
  EXPECT_EQ(parameter_of([] { check_step(kInf, "x"); }), "x");
  EXPECT_EQ(parameter_of([] { check_step(kNaN, "x"); }), "x");
  EXPECT_EQ(parameter_of([] { check_step(kMinStep, "x"); }), "");
  EXPECT_EQ(parameter_of([] { check_step(kMaxStep, "x"); }), "");
  RenderOptions o;
  o.step = 1e-9;
  EXPECT_EQ(parameter_of([&] { RayCaster(TransferFunction::preset("grayscale"), o); }), "RenderOptions::step");
  FrameSettings f;
  f.step = 1e-9;
  EXPECT_EQ(parameter_of([&] { validate(f); }), "FrameSettings::step");
}

TEST(RenderParameterLimits, FrameSettingsAndSessionOptionsNameTheField) {
  FrameSettings f;
  EXPECT_EQ(parameter_of([&] { validate(f); }), "");
  f.lod = kInf;
  EXPECT_EQ(parameter_of([&] { validate(f); }), "FrameSettings::lod");
  f = {};
  f.lod_bias = kNaN;
  EXPECT_EQ(parameter_of([&] { validate(f); }), "FrameSettings::lod_bias");
  f = {};
  f.rank = -1;
  EXPECT_EQ(parameter_of([&] { validate(f); }), "FrameSettings::rank");
  f = {};
  f.camera.orbit.azimuth_deg = kNaN;
  EXPECT_EQ(parameter_of([&] { validate(f); }), "OrbitParams::azimuth_deg");

  SessionOptions s;
  EXPECT_EQ(parameter_of([&] { validate(s); }), "");
  s.target_fps = kInf;
  EXPECT_EQ(parameter_of([&] { validate(s); }), "SessionOptions::target_fps");
  s = {};
  s.max_bricks = 0;
  EXPECT_EQ(parameter_of([&] { validate(s); }), "SessionOptions::max_bricks");
  s = {};
  s.cache_bytes = 0;
  EXPECT_EQ(parameter_of([&] { validate(s); }), "SessionOptions::cache_bytes");
  s = {};
  s.background[0] = float(kNaN);
  EXPECT_EQ(parameter_of([&] { validate(s); }), "SessionOptions::background");
}

}  // namespace
}  // namespace strata::render
