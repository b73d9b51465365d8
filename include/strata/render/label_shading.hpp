#pragma once
/// @file
/// @brief Pre-filtered lighting of a label volume from its normals graph (paper 4, "Lighting";
/// mixture/label_normals.hpp). The normals graph is a label volume of 9-bit normal codes; its
/// "colour map" gives each code the diffuse factor ambient + (1 − ambient)·|n·l| (red) and
/// the specular term specular·|n·l|^shininess (green) of a light at infinity along `towards`
/// (a headlight: the half vector is the light itself). Propagated through the graph like any
/// palette, every node of every level holds the mean light over its footprint: shading is
/// filtered with the colours, never by averaging normals. Code 0 (no normal) gets the mean
/// diffuse factor of the sphere, ambient + (1 − ambient)/2, and no specular term.
#include <memory>

#include "strata/core/vec3.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/label_scene.hpp"

namespace strata::render {

/// @brief A light at infinity and its Blinn-Phong terms.
struct LabelLight {
  Vec3 towards{0, 0, 1};   ///< unit vector from the surface towards the light (world space)
  double ambient = 0.35;   ///< 0..1
  double specular = 0.25;  ///< 0..1
  double shininess = 24;   ///< > 0
  bool operator==(const LabelLight&) const = default;
};

/// @brief The shading factors of one normal code under `light` (red: diffuse, green: specular).
LabelRgba shade_normal_code(int code, const LabelLight& light);

/// @brief The normals graph of a label file as a scene whose palette is the light (red: diffuse,
/// green: specular), rebuilt when the light changes.
class LabelShading {
 public:
  /// @brief Takes the normals graph (mixture::EncodedLabels::open_normals()).
  explicit LabelShading(std::unique_ptr<mixture::EncodedLabels> normals);

  /// @brief A new light rebuilds the palette at the next prepare() (the node ids stay cached).
  void set_light(const LabelLight& light);
  /// @brief As LabelScene::prepare (no skip grids: shading never decides what is empty).
  LabelPrepareReport prepare(int finest_level) { return scene_.prepare(finest_level, false); }
  /// @brief The lit scene the label ray caster samples (valid after prepare()).
  const LabelScene& scene() const { return scene_; }

 private:
  std::unique_ptr<mixture::EncodedLabels> normals_;
  LabelScene scene_;
  LabelLight light_;
  bool lit_ = false;
};

}  // namespace strata::render
