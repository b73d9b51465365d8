#pragma once
// Per-label RGBA colours for rendering segmentation volumes, keyed by the ORIGINAL label value
// (not the dense source id of the Mixture Graph), so a colour map stays valid for every file
// that uses the same label values.
//
// JSON format (all colour components in 0..1, straight - not premultiplied - alpha; alpha is
// the opacity of one level-0 voxel thickness):
//   {
//     "default": "hash" | [r, g, b] | [r, g, b, a],   // unlisted labels; default "hash"
//     "hash_opacity": 1.0,                             // alpha of hash colours; default 1
//     "labels": { "17": [r, g, b, a], "-3": [r, g, b], ... }   // decimal label values
//   }
// Label 0 is the background: transparent unless "labels" lists "0". A colour without alpha is
// opaque. "hash" gives every label a deterministic, well-saturated colour from its value.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/mixture/label_map.hpp"

namespace strata::render {

struct LabelRgba {
  float r = 0, g = 0, b = 0, a = 0;  // straight alpha, 0..1
  bool operator==(const LabelRgba&) const = default;
};

// Deterministic colour of a label value (same value, same colour, on every machine).
LabelRgba hash_label_color(std::int64_t label, float opacity = 1.0f);

class LabelColorMap {
 public:
  // Hash colours for every label, label 0 transparent.
  LabelColorMap();

  // Every label except 0 gets `color` (0 stays transparent unless set()).
  static LabelColorMap uniform(LabelRgba color);
  // `name` names the source (a file) in errors: "<name>: labels.17: ...".
  static LabelColorMap from_json(const nlohmann::json& j, const std::string& name);
  static LabelColorMap load(const std::filesystem::path& path);  // throws Error naming the file

  void set(std::int64_t label, LabelRgba color);  // an explicit colour; also for label 0
  void set_default(LabelRgba color);              // unlisted labels get `color`

  LabelRgba color_of(std::int64_t label) const;

  // Premultiplied RGBA (r a, g a, b a, a) per source id of `map`, row-major (size 4 N): what
  // the palette propagation mixes, since premultiplied colours average correctly across
  // label boundaries (a half-transparent mix keeps the visible label's hue).
  std::vector<float> premultiplied_sources(const mixture::LabelMap& map) const;

 private:
  std::map<std::int64_t, LabelRgba> explicit_;
  std::optional<LabelRgba> default_;  // empty = hash colours
  float hash_opacity_ = 1.0f;
};

}  // namespace strata::render
