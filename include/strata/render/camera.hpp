#pragma once
/// @file
/// @brief An orbit camera: it looks at `target` from `distance` away, at `azimuth` degrees
/// around the world z axis and `elevation` degrees above the xy plane. Produces primary rays per
/// pixel and the lod::View the brick selection needs.
///
/// Orientation (world space as defined in strata/lod/view.hpp, level-0 voxel units times spacing):
///   azimuth 0, elevation 0: the eye is on the -y side of the target looking along +y, with
///   world +x to the right of the image and world +z up. Positive azimuth moves the eye
///   counter-clockwise seen from +z (towards +x); positive elevation moves it towards +z.
///   The image right vector is (cos az, sin az, 0) for every elevation, so looking straight down
///   (elevation +-90) stays well defined.
#include <cstdint>

#include "strata/core/extent.hpp"
#include "strata/core/vec3.hpp"
#include "strata/core/volume.hpp"
#include "strata/lod/view.hpp"

namespace strata::render {

/// @brief How rays leave the eye: from one point (perspective) or parallel (orthographic).
enum class Projection : std::uint8_t { perspective, orthographic };

/// @brief A primary ray in world space.
struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit length
};

/// @brief Where the eye is: angles and distance about a target.
struct OrbitParams {
  double azimuth_deg = 30;
  double elevation_deg = 20;
  double distance = 0;       // world units from target; 0 = frame the whole volume
  Vec3 target;               // world point looked at
  bool target_set = false;   // false = the volume centre
};

/// @brief Everything that defines a camera: image size, projection, orbit and framing.
struct CameraSpec {
  int width = 1024, height = 768;
  Projection projection = Projection::perspective;
  double fov_deg = 30;       // vertical field of view (perspective)
  OrbitParams orbit;
  // Orthographic only: world-space height of the image. 0 = the height the perspective view
  // has at the target plane (2 distance tan(fov/2)), so switching projection keeps the framing.
  double ortho_height = 0;
  // What the default distance (orbit.distance 0) frames: a sphere of this radius (world units)
  // about the target; 0 = the volume's bounding sphere. RenderSession sets it to the sphere
  // about the volume centre that holds the volume's content (its non-empty bricks or voxels),
  // so a brain with empty margins fills the view.
  double frame_radius = 0;
};

/// @brief Limits of a CameraSpec (validate): image edges in pixels, |azimuth| in degrees (any
/// turn is reachable; beyond this the angle loses precision), distance in world units.
inline constexpr int kMaxImageEdge = 16384;
inline constexpr double kMaxAzimuthDeg = 1e6;
inline constexpr double kMaxDistance = 1e12;

/// @brief Throws ParameterError naming the field ("CameraSpec::width", "OrbitParams::azimuth_deg",
/// ...) unless the image is 1..kMaxImageEdge pixels per edge, the field of view lies in (0, 180)
/// degrees, the azimuth is finite within +-kMaxAzimuthDeg, the elevation lies in [-90, 90], the
/// distance in [0, kMaxDistance], and the orthographic height and a set target are finite.
void validate(const CameraSpec& spec);

/// @brief A CameraSpec resolved for one volume: eye, axes and image plane; rays per pixel.
class Camera {
 public:
  /// @brief Resolves defaults (target = volume centre, distance framing the volume's bounding
  /// sphere, or CameraSpec::frame_radius, in both the vertical and the horizontal field of
  /// view). Throws ParameterError when validate(spec) does.
  Camera(const CameraSpec& spec, const Extent& volume_dims, const Spacing& spacing);

  int width() const { return spec_.width; }
  int height() const { return spec_.height; }
  /// @brief The spec with its defaults resolved (target, distance).
  const CameraSpec& spec() const { return spec_; }
  Vec3 eye() const { return eye_; }
  Vec3 forward() const { return forward_; }
  Vec3 right() const { return right_; }
  Vec3 up() const { return up_; }
  Vec3 target() const { return spec_.orbit.target; }
  double distance() const { return spec_.orbit.distance; }
  bool perspective() const { return spec_.projection == Projection::perspective; }
  /// @brief Half extents of the image plane: perspective, tangents of the half angles;
  /// orthographic, world units.
  double half_width() const { return half_width_; }
  double half_height() const { return half_height_; }

  /// @brief Ray through the centre of pixel (px, py); py = 0 is the top row. Fractional
  /// positions address sub-pixel points (pixel (0,0) spans [-0.5, 0.5) around its centre).
  Ray ray(double px, double py) const;
  /// @brief The view the LOD selection and the label caster's footprints use.
  lod::View view() const;

 private:
  CameraSpec spec_;
  Vec3 eye_, forward_, right_, up_;
  double half_height_ = 1;  // perspective: tan(fov/2); orthographic: half image height in world units
  double half_width_ = 1;   // half_height * aspect
  double far_ = 1;          // distance of the far plane from the eye
};

}  // namespace strata::render
