// POST /api/datasets/{id}/palette and GET /api/datasets/{id}/query: label colours through the
// Mixture Graph and box histograms (mixture::BoxQuery).
#include <algorithm>
#include <cctype>

#include <fmt/format.h>

#include "server/api_detail.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/mixture/encoded_labels.hpp"

namespace strata::server::detail {

namespace {

using render::DatasetKind;

// "#rrggbb" -> straight RGB in [0, 1] with opacity `alpha`.
render::LabelRgba parse_hex_color(const nlohmann::json& value, float alpha, const std::string& field) {
  const std::string text = value.is_string() ? value.get<std::string>() : std::string();
  const bool ok = text.size() == 7 && text[0] == '#' && std::all_of(text.begin() + 1, text.end(), [](char c) {
    return std::isxdigit(static_cast<unsigned char>(c)) != 0;
  });
  if (!ok) bad_parameter(field, "expected a colour \"#rrggbb\"");
  auto channel = [&](int i) { return float(std::stoi(text.substr(std::size_t(1 + 2 * i), 2), nullptr, 16)) / 255.0f; };
  return {channel(0), channel(1), channel(2), alpha};
}

// A label key or list entry that names a label of the dataset.
std::int64_t parse_label(const nlohmann::json& value, const Dataset& d, const std::string& field) {
  std::optional<std::int64_t> label;
  if (value.is_number_integer()) label = value.get<std::int64_t>();
  if (value.is_string()) label = parse_integer(value.get<std::string>());
  if (!label) bad_parameter(field, "expected a label value (an integer)");
  if (!d.session->has_label(*label)) bad_parameter(field, fmt::format("label {} does not occur in dataset {}", *label, d.id));
  return *label;
}

render::LabelColorMap parse_palette(const Dataset& d, const std::string& body) {
  const nlohmann::json j = nlohmann::json::parse(body, nullptr, false);
  if (j.is_discarded() || !j.is_object()) bad_parameter("body", "expected a JSON object");
  for (const auto& [key, value] : j.items())
    if (key != "colors" && key != "hidden" && key != "only" && key != "default" && key != "opacity")
      bad_parameter(key, "unknown field (expected colors, hidden, only, default, opacity)");
  float opacity = 1;
  if (j.contains("opacity")) {
    const nlohmann::json& o = j["opacity"];
    if (!o.is_number() || !(o.get<double>() >= 0 && o.get<double>() <= 1)) bad_parameter("opacity", "expected a number in [0, 1]");
    opacity = o.get<float>();
  }
  // Hash colours unless "default" names one colour; label 0 stays transparent unless listed.
  render::LabelColorMap map = render::LabelColorMap::from_json({{"hash_opacity", opacity}}, "palette");
  if (j.contains("default") && j["default"] != "hash") map.set_default(parse_hex_color(j["default"], opacity, "default"));
  if (j.contains("colors")) {
    if (!j["colors"].is_object()) bad_parameter("colors", "expected an object {\"<label>\": \"#rrggbb\"}");
    for (const auto& [key, value] : j["colors"].items())
      map.set(parse_label(key, d, "colors." + key), parse_hex_color(value, opacity, "colors." + key));
  }
  if (j.contains("only")) {
    // Show only these labels: each keeps the colour it has now, every other label (those to
    // come, through the default) turns transparent. One list, whatever the label count.
    if (!j["only"].is_array()) bad_parameter("only", "expected an array of labels");
    std::vector<std::pair<std::int64_t, render::LabelRgba>> shown;
    for (const nlohmann::json& label : j["only"]) {
      const std::int64_t l = parse_label(label, d, "only");
      shown.emplace_back(l, map.color_of(l));
    }
    map.set_default({0, 0, 0, 0});
    for (const auto& [label, color] : shown) map.set(label, color);
  }
  if (j.contains("hidden")) {
    if (!j["hidden"].is_array()) bad_parameter("hidden", "expected an array of labels");
    for (const nlohmann::json& label : j["hidden"]) map.set(parse_label(label, d, "hidden"), {0, 0, 0, 0});
  }
  return map;
}

Box parse_query_box(const Params& p, const Extent& dims) {
  const auto b = p.integers("box", 6);
  if (!b) bad_parameter("box", "required: x0,y0,z0,x1,y1,z1 (half-open, level-0 voxels)");
  const Box box{{(*b)[0], (*b)[1], (*b)[2]}, {(*b)[3], (*b)[4], (*b)[5]}};
  if (box.empty() || !Box::whole(dims).contains(box))
    bad_parameter("box", fmt::format("expected a non-empty box inside the volume [0, {}) x [0, {}) x [0, {})", dims.x,
                                     dims.y, dims.z));
  return box;
}

}  // namespace

HttpResponse set_palette(Dataset& d, const HttpRequest& r) {
  require_kind(d, {DatasetKind::labels}, "id");
  const Params p(r, {});
  render::LabelColorMap colors = parse_palette(d, r.body);
  std::lock_guard lock(d.mutex);
  const double ms = d.session->set_label_colors(std::move(colors));
  return json_response({{"palette_ms", ms}, {"labels", d.session->labels().label_map().size()}});
}

HttpResponse query_box(Dataset& d, const HttpRequest& r) {
  require_kind(d, {DatasetKind::labels}, "id");
  const Params p(r, {"box", "method"});
  const Box box = parse_query_box(p, d.session->dims());
  const std::string method = p.choice("method", {"hybrid", "footprint", "naive", "coarse"}, "hybrid");
  const mixture::BoxQuery& query = d.box_query();
  const auto t0 = SteadyClock::now();
  mixture::QueryOptions options;
  options.method = mixture::parse_query_method(method);
  mixture::BoxHistogram h = query.run(box, options);
  const double ms = ms_since(t0);
  std::stable_sort(h.counts.begin(), h.counts.end(),
                   [](const mixture::BoxCount& a, const mixture::BoxCount& b) { return a.count > b.count; });
  const mixture::LabelMap& map = d.session->labels().label_map();
  nlohmann::json labels = nlohmann::json::array();
  for (const mixture::BoxCount& c : h.counts)
    labels.push_back({{"label", map.value(c.source)}, {"count", c.count}, {"sigma", c.sigma}});
  return json_response({{"box", {box.lo.x, box.lo.y, box.lo.z, box.hi.x, box.hi.y, box.hi.z}},
                        {"method", method},
                        {"ms", ms},
                        {"voxels", box.voxel_count()},
                        {"labels", std::move(labels)}});
}

}  // namespace strata::server::detail
