#include "strata/render/transfer_function.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/io/files.hpp"
#include "strata/lod/histogram_bins.hpp"

namespace strata::render {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string point_field(std::size_t i, const char* member) {
  return "points[" + std::to_string(i) + "]" + (member[0] ? std::string(".") + member : std::string());
}

// Closed intervals of x where the piecewise-linear alpha is positive, merged.
std::vector<std::pair<double, double>> visible_intervals(const std::vector<TfPoint>& p) {
  std::vector<std::pair<double, double>> out;
  auto add = [&](double lo, double hi) {
    if (!out.empty() && lo <= out.back().second) out.back().second = std::max(out.back().second, hi);
    else out.emplace_back(lo, hi);
  };
  if (p.front().rgba[3] > 0) add(-kInf, p.front().x);
  for (std::size_t i = 0; i + 1 < p.size(); ++i)
    if (p[i].rgba[3] > 0 || p[i + 1].rgba[3] > 0) add(p[i].x, p[i + 1].x);
  if (p.back().rgba[3] > 0) add(p.back().x, kInf);
  return out;
}

double json_number(const nlohmann::json& j, const std::string& source, const std::string& field) {
  if (!j.is_number()) throw FormatError(source, field, "expected a number, found " + j.dump());
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw FormatError(source, field, "must be finite");
  return v;
}

TfPoint parse_point(const nlohmann::json& j, std::size_t i, const std::string& source) {
  if (!j.is_object()) throw FormatError(source, point_field(i, ""), "expected an object {\"x\": .., \"rgba\": [..]}");
  if (!j.contains("x")) throw FormatError(source, point_field(i, "x"), "missing");
  if (!j.contains("rgba")) throw FormatError(source, point_field(i, "rgba"), "missing");
  TfPoint p;
  p.x = json_number(j["x"], source, point_field(i, "x"));
  if (p.x < 0 || p.x > 1) throw FormatError(source, point_field(i, "x"), "must lie in [0, 1]");
  const nlohmann::json& c = j["rgba"];
  if (!c.is_array() || c.size() != 4)
    throw FormatError(source, point_field(i, "rgba"), "expected 4 numbers [r, g, b, a] in [0, 1]");
  for (int k = 0; k < 4; ++k) {
    const double v = json_number(c[std::size_t(k)], source, point_field(i, "rgba") + "[" + std::to_string(k) + "]");
    if (v < 0 || v > 1)
      throw FormatError(source, point_field(i, "rgba") + "[" + std::to_string(k) + "]", "must lie in [0, 1]");
    p.rgba[std::size_t(k)] = float(v);
  }
  return p;
}

std::optional<std::pair<double, double>> parse_range(const nlohmann::json& j, const std::string& source) {
  if (!j.contains("range") || j["range"].is_null()) return std::nullopt;
  const nlohmann::json& r = j["range"];
  if (!r.is_array() || r.size() != 2) throw FormatError(source, "range", "expected [lo, hi] in data values");
  const double lo = json_number(r[0], source, "range[0]"), hi = json_number(r[1], source, "range[1]");
  if (!(lo < hi)) throw FormatError(source, "range", "expected lo < hi");
  return std::pair{lo, hi};
}

struct Preset {
  std::string_view name;
  std::vector<TfPoint> points;
};

// Opacities are per level-0 voxel, so they stay low: a 256-voxel ray through alpha 0.02
// still lets 0.6% through.
const std::vector<Preset>& presets() {
  static const std::vector<Preset> all = {
      {"grayscale", {{0.0, {0, 0, 0, 0}}, {0.1, {0.1f, 0.1f, 0.1f, 0}}, {1.0, {1, 1, 1, 0.25f}}}},
      {"ct",
       {{0.0, {0, 0, 0, 0}},
        {0.25, {0.55f, 0.25f, 0.15f, 0}},
        {0.35, {0.8f, 0.45f, 0.3f, 0.015f}},
        {0.45, {0.9f, 0.6f, 0.45f, 0.02f}},
        {0.55, {0.95f, 0.9f, 0.8f, 0.5f}},
        {1.0, {1, 1, 1, 0.9f}}}},
      {"mri",
       {{0.0, {0, 0, 0, 0}},
        {0.15, {0.2f, 0.1f, 0.1f, 0}},
        {0.4, {0.7f, 0.5f, 0.4f, 0.02f}},
        {0.7, {0.95f, 0.85f, 0.75f, 0.15f}},
        {1.0, {1, 1, 1, 0.4f}}}},
      {"fire",
       {{0.0, {0, 0, 0, 0}},
        {0.2, {0.3f, 0, 0, 0}},
        {0.45, {0.9f, 0.1f, 0, 0.03f}},
        {0.7, {1, 0.6f, 0, 0.12f}},
        {1.0, {1, 1, 0.8f, 0.5f}}}},
  };
  return all;
}

constexpr std::array<std::string_view, 5> kPresetNames = {"grayscale", "ct", "bone", "mri", "fire"};

// "grayscale, ct, bone, mri, fire" for error messages.
std::string joined_preset_names() {
  std::string names;
  for (std::string_view n : kPresetNames) names += (names.empty() ? "" : ", ") + std::string(n);
  return names;
}

}  // namespace

float correct_opacity(float alpha, double ratio) {
  if (alpha >= 1.0f) return 1.0f;
  if (alpha <= 0.0f) return 0.0f;
  return float(1.0 - std::pow(1.0 - double(alpha), ratio));
}

TransferFunction::TransferFunction(std::vector<TfPoint> points, std::optional<std::pair<double, double>> range)
    : points_(std::move(points)), range_(range) {
  if (points_.empty()) throw Error("transfer function: needs at least one point");
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (!(points_[i].x >= 0 && points_[i].x <= 1)) throw Error("transfer function: " + point_field(i, "x") + " outside [0, 1]");
    if (i > 0 && points_[i].x < points_[i - 1].x)
      throw Error("transfer function: " + point_field(i, "x") + " is smaller than the previous point's x");
    for (float c : points_[i].rgba)
      if (!(c >= 0 && c <= 1)) throw Error("transfer function: " + point_field(i, "rgba") + " outside [0, 1]");
  }
  if (range_ && !(range_->first < range_->second)) throw Error("transfer function: range needs lo < hi");
  visible_ = visible_intervals(points_);
}

TransferFunction TransferFunction::from_json(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object()) throw FormatError(source, "(document)", "expected a JSON object with \"points\"");
  if (!j.contains("points")) throw FormatError(source, "points", "missing");
  const nlohmann::json& pts = j["points"];
  if (!pts.is_array() || pts.empty()) throw FormatError(source, "points", "expected a non-empty array");
  std::vector<TfPoint> points;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    points.push_back(parse_point(pts[i], i, source));
    if (i > 0 && points[i].x < points[i - 1].x)
      throw FormatError(source, point_field(i, "x"), "points must be sorted by x (non-decreasing)");
  }
  return TransferFunction(std::move(points), parse_range(j, source));
}

TransferFunction TransferFunction::load(const std::filesystem::path& path) {
  return from_json(io::read_json_file(path, "(document)"), path.string());
}

TransferFunction TransferFunction::preset(std::string_view name) {
  const std::string_view key = name == "bone" ? std::string_view("ct") : name;
  for (const Preset& p : presets())
    if (p.name == key) return TransferFunction(p.points);
  throw Error("transfer function preset \"" + std::string(name) + "\" is unknown; presets: " + joined_preset_names());
}

std::span<const std::string_view> TransferFunction::preset_names() { return kPresetNames; }

TransferFunction TransferFunction::from_argument(const std::string& preset_or_path) {
  for (std::string_view n : kPresetNames)
    if (n == preset_or_path) return preset(n);
  if (std::filesystem::exists(preset_or_path)) return load(preset_or_path);
  throw ParameterError("preset_or_path", "\"" + preset_or_path + "\" is neither a preset (" + joined_preset_names() +
                                            ") nor an existing JSON file");
}

bool TransferFunction::is_preset(std::string_view name) {
  return std::find(kPresetNames.begin(), kPresetNames.end(), name) != kPresetNames.end();
}

namespace {

// The fields of one `v:r:g:b:a` point; throws ParameterError("text") naming point `i`.
std::array<double, 5> parse_text_point(std::string_view point, std::size_t i) {
  const std::string what = "point " + std::to_string(i) + " \"" + std::string(point) + "\"";
  std::array<double, 5> f{};
  std::size_t k = 0, start = 0;
  for (; start <= point.size() && k < f.size(); ++k) {
    const std::size_t colon = std::min(point.find(':', start), point.size());
    const char* first = point.data() + start;
    const char* last = point.data() + colon;
    const auto [end, ec] = std::from_chars(first, last, f[k]);
    if (ec != std::errc() || end != last || !std::isfinite(f[k]))
      throw ParameterError("text", what + ": expected v:r:g:b:a, five finite numbers");
    start = colon + 1;
  }
  if (k != f.size() || start <= point.size())
    throw ParameterError("text", what + ": expected v:r:g:b:a, five finite numbers");
  for (std::size_t c = 1; c < f.size(); ++c)
    if (!(f[c] >= 0 && f[c] <= 1)) throw ParameterError("text", what + ": r, g, b and a must lie in [0, 1]");
  return f;
}

}  // namespace

TransferFunction TransferFunction::from_points_text(std::string_view text) {
  std::vector<std::array<double, 5>> fields;
  for (std::size_t start = 0; start <= text.size();) {
    const std::size_t semi = std::min(text.find(';', start), text.size());
    fields.push_back(parse_text_point(text.substr(start, semi - start), fields.size()));
    start = semi + 1;
  }
  if (fields.size() < 2) throw ParameterError("text", "needs at least two points v:r:g:b:a separated by ';'");
  for (std::size_t i = 1; i < fields.size(); ++i)
    if (fields[i][0] < fields[i - 1][0])
      throw ParameterError("text", "point " + std::to_string(i) + ": values must be in ascending order");
  const double lo = fields.front()[0], hi = fields.back()[0];
  if (!(lo < hi)) throw ParameterError("text", "the first point's value must lie below the last one's");
  std::vector<TfPoint> points;
  for (const auto& f : fields)
    points.push_back({std::clamp((f[0] - lo) / (hi - lo), 0.0, 1.0), {float(f[1]), float(f[2]), float(f[3]), float(f[4])}});
  return TransferFunction(std::move(points), std::pair{lo, hi});
}

nlohmann::json TransferFunction::to_json() const {
  nlohmann::json j;
  nlohmann::json pts = nlohmann::json::array();
  for (const TfPoint& p : points_)
    pts.push_back({{"x", p.x}, {"rgba", {p.rgba[0], p.rgba[1], p.rgba[2], p.rgba[3]}}});
  j["points"] = std::move(pts);
  if (range_) j["range"] = {range_->first, range_->second};
  return j;
}

ValueMapping TransferFunction::mapping(double volume_lo, double volume_hi) const {
  if (range_) return {range_->first, range_->second};
  return {volume_lo, volume_hi};
}

Rgbaf TransferFunction::evaluate(double x) const {
  // The last point with p.x <= x (right-continuous at steps), then interpolate to the next.
  const auto next = std::upper_bound(points_.begin(), points_.end(), x,
                                     [](double v, const TfPoint& p) { return v < p.x; });
  auto to_rgba = [](const std::array<float, 4>& c) { return Rgbaf{c[0], c[1], c[2], c[3]}; };
  if (next == points_.begin()) return to_rgba(points_.front().rgba);
  if (next == points_.end()) return to_rgba(points_.back().rgba);
  const TfPoint& a = *(next - 1);
  const TfPoint& b = *next;
  const float w = float((x - a.x) / (b.x - a.x));  // b.x > a.x: equal x never follows upper_bound's result
  Rgbaf out;
  out.r = a.rgba[0] + w * (b.rgba[0] - a.rgba[0]);
  out.g = a.rgba[1] + w * (b.rgba[1] - a.rgba[1]);
  out.b = a.rgba[2] + w * (b.rgba[2] - a.rgba[2]);
  out.a = a.rgba[3] + w * (b.rgba[3] - a.rgba[3]);
  return out;
}

bool TransferFunction::visible(double x_lo, double x_hi) const {
  if (x_hi < x_lo) std::swap(x_lo, x_hi);
  for (const auto& [lo, hi] : visible_)
    if (lo <= x_hi && x_lo <= hi) return true;
  return false;
}

std::uint64_t TransferFunction::visible_bins(double value_lo, double value_hi) const {
  const ValueMapping m = mapping(value_lo, value_hi);
  if (!(value_hi > value_lo)) return visible(m.normalise(value_lo), m.normalise(value_lo)) ? ~std::uint64_t(0) : 0;
  const int bins = store::kHistogramBins;
  const double width = (value_hi - value_lo) / bins;
  std::uint64_t mask = 0;
  for (int i = 0; i < bins; ++i) {
    const double lo = i == 0 ? -kInf : m.normalise(value_lo + i * width);
    const double hi = i == bins - 1 ? kInf : m.normalise(value_lo + (i + 1) * width);
    if (visible(lo, hi)) mask |= std::uint64_t(1) << i;
  }
  return mask;
}

LookupTable TransferFunction::lookup_table(int size, double ratio) const {
  if (size < 2) throw Error("transfer function: lookup table needs at least 2 entries");
  LookupTable t{size, ratio, std::vector<Rgbaf>(std::size_t(size))};
  for (int i = 0; i < size; ++i) {
    const Rgbaf c = evaluate(double(i) / (size - 1));
    const float a = correct_opacity(c.a, ratio);
    t.entries[std::size_t(i)] = {c.r * a, c.g * a, c.b * a, a};
  }
  return t;
}

PreintegratedTable TransferFunction::preintegrated_table(int size, double ratio) const {
  if (size < 2) throw Error("transfer function: pre-integrated table needs at least 2 entries");
  // The ramp is integrated numerically on a fine straight-colour table of extinction
  // coefficients (tau = -ln(1 - alpha) per reference step), with enough sub-segments that each
  // spans at most one fine entry, capped so building a table stays in the tens of milliseconds.
  constexpr int kFine = 2048, kMaxSub = 256;
  std::vector<Rgbaf> fine(kFine);
  for (int i = 0; i < kFine; ++i) {
    Rgbaf c = evaluate(double(i) / (kFine - 1));
    c.a = c.a >= 1.0f ? 1e30f : float(-std::log1p(-double(c.a)));
    fine[std::size_t(i)] = c;
  }
  // Sub-segment transparencies exp(-tau * ratio / n) depend only on the fine entry and the
  // sub-segment count n, so they are tabulated once per n (2048 exps each instead of one per
  // sub-segment of every pair): the same doubles as evaluating them in the loop.
  const int max_n = kMaxSub;
  std::vector<double> transmit(std::size_t(max_n + 1) * kFine);
#pragma omp parallel for schedule(static) num_threads(thread_count())
  for (int n = 2; n <= max_n; ++n)
    for (int i = 0; i < kFine; ++i)
      transmit[std::size_t(n) * kFine + std::size_t(i)] = std::exp(-double(fine[std::size_t(i)].a) * (ratio / n));
  PreintegratedTable t{size, ratio, std::vector<Rgbaf>(std::size_t(size) * std::size_t(size))};
#pragma omp parallel for schedule(dynamic, 4) num_threads(thread_count())
  for (int f = 0; f < size; ++f) {
    for (int b = 0; b < size; ++b) {
      const double xf = double(f) / (size - 1), xb = double(b) / (size - 1);
      const int n = std::clamp(int(std::ceil(std::abs(xb - xf) * (kFine - 1))) + 1, 1, kMaxSub);
      if (n == 1) {  // constant segment: exactly the opacity-corrected classification
        const Rgbaf c = evaluate(0.5 * (xf + xb));
        const float a = correct_opacity(c.a, ratio);
        t.entries[std::size_t(f) * std::size_t(size) + std::size_t(b)] = {c.r * a, c.g * a, c.b * a, a};
        continue;
      }
      // Front to back with the transmittance T = 1 - alpha so far as the only loop-carried
      // product (one multiplication per sub-segment instead of a subtract-multiply-add chain).
      double cr = 0, cg = 0, cb = 0, transmittance = 1;
      const double* tr = transmit.data() + std::size_t(n) * kFine;
      const double dx = (xb - xf) / n;
      for (int k = 0; k < n && transmittance > 1e-4; ++k) {
        const double u = (xf + dx * (k + 0.5)) * (kFine - 1);  // >= 0: std::lround without the call
        std::size_t i = std::size_t(u);
        if (u - double(i) >= 0.5) ++i;
        const Rgbaf& c = fine[i];
        const double w = transmittance * (1.0 - tr[i]);
        cr += w * c.r;
        cg += w * c.g;
        cb += w * c.b;
        transmittance *= tr[i];
      }
      t.entries[std::size_t(f) * std::size_t(size) + std::size_t(b)] = {float(cr), float(cg), float(cb),
                                                                         float(1.0 - transmittance)};
    }
  }
  return t;
}

}  // namespace strata::render
