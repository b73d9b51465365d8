#include "strata/render/camera.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "strata/core/error.hpp"

namespace strata::render {

namespace {

double radians(double deg) { return deg * std::numbers::pi / 180.0; }

}  // namespace

void validate(const CameraSpec& spec) {
  const auto edge = [](int v, const char* field) {
    if (v < 1 || v > kMaxImageEdge)
      throw ParameterError(field, fmt::format("must lie in 1..{} pixels, got {}", kMaxImageEdge, v));
  };
  edge(spec.width, "CameraSpec::width");
  edge(spec.height, "CameraSpec::height");
  if (!(spec.fov_deg > 0 && spec.fov_deg < 180))
    throw ParameterError("CameraSpec::fov_deg", fmt::format("must lie in (0, 180) degrees, got {}", spec.fov_deg));
  if (!(std::isfinite(spec.ortho_height) && spec.ortho_height >= 0))
    throw ParameterError("CameraSpec::ortho_height", fmt::format("must be finite and >= 0, got {}", spec.ortho_height));
  if (!(std::isfinite(spec.frame_radius) && spec.frame_radius >= 0))
    throw ParameterError("CameraSpec::frame_radius", fmt::format("must be finite and >= 0, got {}", spec.frame_radius));
  const OrbitParams& o = spec.orbit;
  if (!(std::abs(o.azimuth_deg) <= kMaxAzimuthDeg))
    throw ParameterError("OrbitParams::azimuth_deg",
                         fmt::format("must be a finite angle in [-{0}, {0}] degrees, got {1}", kMaxAzimuthDeg, o.azimuth_deg));
  if (!(std::abs(o.elevation_deg) <= 90))
    throw ParameterError("OrbitParams::elevation_deg",
                         fmt::format("must lie in [-90, 90] degrees, got {}", o.elevation_deg));
  if (!(o.distance >= 0 && o.distance <= kMaxDistance))
    throw ParameterError("OrbitParams::distance",
                         fmt::format("must lie in [0, {:g}] world units (0 = fit the volume), got {}", kMaxDistance,
                                     o.distance));
  if (o.target_set && !(std::isfinite(o.target.x) && std::isfinite(o.target.y) && std::isfinite(o.target.z)))
    throw ParameterError("OrbitParams::target", "components must be finite");
}

namespace {

// Inward-facing plane through `point` with normal `n` (normalised here).
lod::Plane plane_through(const Vec3& n, const Vec3& point) {
  const Vec3 u = normalized(n);
  return {u, -dot(u, point)};
}

}  // namespace

Camera::Camera(const CameraSpec& spec, const Extent& volume_dims, const Spacing& spacing) : spec_(spec) {
  validate(spec_);
  const Vec3 size{double(volume_dims.x) * spacing.x, double(volume_dims.y) * spacing.y,
                  double(volume_dims.z) * spacing.z};
  // Radius of the volume's bounding sphere (world units): frames the volume and sets the far plane.
  const double scene_radius = std::max(0.5 * length(size), 1e-9);
  OrbitParams& orbit = spec_.orbit;
  if (!orbit.target_set) {
    orbit.target = size * 0.5;
    orbit.target_set = true;
  }
  const double aspect = double(spec_.width) / double(spec_.height);
  const double tan_v = std::tan(radians(spec_.fov_deg) * 0.5);
  const double tan_h = tan_v * aspect;
  if (orbit.distance == 0) {
    // The sphere fits a cone of half-angle a when distance = r / sin(a); take the narrower
    // of the two half-angles so neither image axis clips the volume.
    const double half_angle = std::atan(std::min(tan_v, tan_h));
    const double framed = spec_.frame_radius > 0 ? std::min(spec_.frame_radius, scene_radius) : scene_radius;
    orbit.distance = framed / std::sin(half_angle);
  }

  const double az = radians(orbit.azimuth_deg), el = radians(orbit.elevation_deg);
  const Vec3 to_eye{std::sin(az) * std::cos(el), -std::cos(az) * std::cos(el), std::sin(el)};
  eye_ = orbit.target + to_eye * orbit.distance;
  forward_ = -to_eye;
  right_ = {std::cos(az), std::sin(az), 0.0};
  up_ = normalized(cross(right_, forward_));

  if (perspective()) {
    half_height_ = tan_v;
  } else {
    const double height = spec_.ortho_height > 0 ? spec_.ortho_height : 2 * orbit.distance * tan_v;
    half_height_ = 0.5 * height;
  }
  half_width_ = half_height_ * aspect;
  // Everything in the volume lies within distance + radius of the eye.
  far_ = orbit.distance + 2 * scene_radius;
}

Ray Camera::ray(double px, double py) const {
  const double u = ((px + 0.5) / spec_.width * 2.0 - 1.0) * half_width_;
  const double v = (1.0 - (py + 0.5) / spec_.height * 2.0) * half_height_;
  if (perspective()) return {eye_, normalized(forward_ + right_ * u + up_ * v)};
  return {eye_ + right_ * u + up_ * v, forward_};
}

lod::View Camera::view() const {
  lod::View view;
  view.eye = eye_;
  view.forward = forward_;
  view.perspective = perspective();
  if (perspective()) {
    view.pixel_angle = radians(spec_.fov_deg) / spec_.height;
    // Side planes contain the eye and one image edge; their inward normals are perpendicular
    // to the edge direction (e.g. forward - right * half_width for the left edge).
    view.frustum[0] = plane_through(right_ + forward_ * half_width_, eye_);
    view.frustum[1] = plane_through(-right_ + forward_ * half_width_, eye_);
    view.frustum[2] = plane_through(up_ + forward_ * half_height_, eye_);
    view.frustum[3] = plane_through(-up_ + forward_ * half_height_, eye_);
  } else {
    view.pixel_world = 2 * half_height_ / spec_.height;
    view.frustum[0] = plane_through(right_, eye_ - right_ * half_width_);
    view.frustum[1] = plane_through(-right_, eye_ + right_ * half_width_);
    view.frustum[2] = plane_through(up_, eye_ - up_ * half_height_);
    view.frustum[3] = plane_through(-up_, eye_ + up_ * half_height_);
  }
  view.frustum[4] = plane_through(forward_, eye_);
  view.frustum[5] = plane_through(-forward_, eye_ + forward_ * far_);
  return view;
}

}  // namespace strata::render
