#pragma once
/// @file
/// @brief Per-label RGBA colours for rendering segmentation volumes, keyed by the ORIGINAL label
/// value (not the dense source id of the Mixture Graph), so a colour map stays valid for every
/// file that uses the same label values.
///
/// JSON format (all colour components in 0..1, straight - not premultiplied - alpha; alpha is
/// the opacity of one level-0 voxel thickness):
///   {
///     "default": "hash" | [r, g, b] | [r, g, b, a],   // unlisted labels; default "hash"
///     "hash_opacity": 1.0,                             // alpha of hash colours; default 1
///     "labels": { "17": [r, g, b, a], "-3": [r, g, b], ... }   // decimal label values
///   }
/// Label 0 is the background: transparent unless "labels" lists "0". A colour without alpha is
/// opaque. "hash" gives every label a deterministic, well-saturated colour from its value.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/mixture/label_map.hpp"

namespace strata::render {

/// @brief A label's colour: straight alpha, components in 0..1.
struct LabelRgba {
  float r = 0, g = 0, b = 0, a = 0;  // straight alpha, 0..1
  bool operator==(const LabelRgba&) const = default;
};

/// @brief Deterministic colour of a label value (same value, same colour, on every machine).
LabelRgba hash_label_color(std::int64_t label, float opacity = 1.0f);

/// @brief The colour of every label value: explicit colours, then a default (a colour or hash
/// colours); label 0 transparent unless set.
class LabelColorMap {
 public:
  /// @brief Hash colours for every label, label 0 transparent.
  LabelColorMap();

  /// @brief Every label except 0 gets `color` (0 stays transparent unless set()).
  static LabelColorMap uniform(LabelRgba color);
  /// @brief The JSON form; `name` names the source (a file) in errors: "<name>: labels.17: ...".
  static LabelColorMap from_json(const nlohmann::json& j, const std::string& name);
  /// @brief A JSON file; throws Error naming the file.
  static LabelColorMap load(const std::filesystem::path& path);

  /// @brief An explicit colour for `label`; also for label 0.
  void set(std::int64_t label, LabelRgba color);
  /// @brief Unlisted labels get `color` (instead of hash colours).
  void set_default(LabelRgba color);

  /// @brief The colour `label` is drawn in.
  LabelRgba color_of(std::int64_t label) const;

  /// @brief Premultiplied RGBA (r a, g a, b a, a) per source id of `map`, row-major (size 4 N):
  /// what the palette propagation mixes, since premultiplied colours average correctly across
  /// label boundaries (a half-transparent mix keeps the visible label's hue).
  std::vector<float> premultiplied_sources(const mixture::LabelMap& map) const;

 private:
  std::map<std::int64_t, LabelRgba> explicit_;
  std::optional<LabelRgba> default_;  // empty = hash colours
  float hash_opacity_ = 1.0f;
};

}  // namespace strata::render
