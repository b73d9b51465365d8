#include "strata/render/label_color_map.hpp"

#include <charconv>
#include <cmath>

#include "strata/core/error.hpp"
#include "strata/core/hash.hpp"
#include "strata/io/files.hpp"

namespace strata::render {

namespace {

float unit(std::uint64_t bits) { return float(bits & 0xffffff) / float(0x1000000); }

// HSV (all 0..1) to RGB.
LabelRgba hsv(float h, float s, float v, float a) {
  const float h6 = h * 6.0f;
  const int sector = int(h6) % 6;
  const float f = h6 - std::floor(h6);
  const float p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  switch (sector) {
    case 0: return {v, t, p, a};
    case 1: return {q, v, p, a};
    case 2: return {p, v, t, a};
    case 3: return {p, q, v, a};
    case 4: return {t, p, v, a};
    default: return {v, p, q, a};
  }
}

float check_unit(const nlohmann::json& v, const std::string& name, const std::string& field) {
  if (!v.is_number()) throw FormatError(name, field, "expected a number in 0..1, got " + v.dump());
  const double x = v.get<double>();
  if (!(x >= 0.0 && x <= 1.0)) throw FormatError(name, field, "expected a number in 0..1, got " + v.dump());
  return float(x);
}

LabelRgba parse_color(const nlohmann::json& v, const std::string& name, const std::string& field) {
  if (!v.is_array() || (v.size() != 3 && v.size() != 4))
    throw FormatError(name, field, "expected [r, g, b] or [r, g, b, a] with values in 0..1, got " + v.dump());
  LabelRgba c;
  c.r = check_unit(v[0], name, field + "[0]");
  c.g = check_unit(v[1], name, field + "[1]");
  c.b = check_unit(v[2], name, field + "[2]");
  c.a = v.size() == 4 ? check_unit(v[3], name, field + "[3]") : 1.0f;
  return c;
}

std::int64_t parse_label_key(const std::string& key, const std::string& name) {
  std::int64_t value = 0;
  const char* end = key.data() + key.size();
  const auto [ptr, ec] = std::from_chars(key.data(), end, value);
  if (key.empty() || ec != std::errc() || ptr != end)
    throw FormatError(name, "labels." + key, "expected a decimal integer label value as the key");
  return value;
}

}  // namespace

LabelRgba hash_label_color(std::int64_t label, float opacity) {
  const std::uint64_t h = splitmix64(std::uint64_t(label));
  // Full hue circle; saturation and value kept high so neighbours stay distinguishable and
  // no label comes out near-black.
  return hsv(unit(h), 0.55f + 0.4f * unit(h >> 24), 0.75f + 0.25f * unit(h >> 48), opacity);
}

LabelColorMap::LabelColorMap() { explicit_[0] = LabelRgba{}; }

LabelColorMap LabelColorMap::uniform(LabelRgba color) {
  LabelColorMap m;
  m.set_default(color);
  return m;
}

void LabelColorMap::set(std::int64_t label, LabelRgba color) { explicit_[label] = color; }
void LabelColorMap::set_default(LabelRgba color) { default_ = color; }

LabelRgba LabelColorMap::color_of(std::int64_t label) const {
  if (const auto it = explicit_.find(label); it != explicit_.end()) return it->second;
  return default_ ? *default_ : hash_label_color(label, hash_opacity_);
}

std::vector<float> LabelColorMap::premultiplied_sources(const mixture::LabelMap& map) const {
  std::vector<float> rows(std::size_t(map.size()) * 4);
  for (std::uint32_t id = 0; id < map.size(); ++id) {
    const LabelRgba c = color_of(map.value(id));
    float* row = rows.data() + std::size_t(id) * 4;
    row[0] = c.r * c.a;
    row[1] = c.g * c.a;
    row[2] = c.b * c.a;
    row[3] = c.a;
  }
  return rows;
}

LabelColorMap LabelColorMap::from_json(const nlohmann::json& j, const std::string& name) {
  if (!j.is_object()) throw FormatError(name, "colour map", "expected a JSON object");
  for (const auto& [key, value] : j.items())
    if (key != "default" && key != "hash_opacity" && key != "labels")
      throw FormatError(name, key, "unknown field (expected default, hash_opacity, labels)");
  LabelColorMap m;
  if (j.contains("hash_opacity")) m.hash_opacity_ = check_unit(j["hash_opacity"], name, "hash_opacity");
  if (j.contains("default")) {
    const nlohmann::json& d = j["default"];
    if (d.is_string()) {
      if (d.get<std::string>() != "hash") throw FormatError(name, "default", "expected \"hash\" or a colour");
    } else {
      m.default_ = parse_color(d, name, "default");
    }
  }
  if (j.contains("labels")) {
    const nlohmann::json& labels = j["labels"];
    if (!labels.is_object()) throw FormatError(name, "labels", "expected an object {\"<label>\": [r, g, b, a]}");
    for (const auto& [key, value] : labels.items())
      m.explicit_[parse_label_key(key, name)] = parse_color(value, name, "labels." + key);
  }
  return m;
}

LabelColorMap LabelColorMap::load(const std::filesystem::path& path) {
  return from_json(io::read_json_file(path, "JSON"), path.string());
}

}  // namespace strata::render
