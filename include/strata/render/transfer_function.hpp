#pragma once
/// @file
/// @brief 1D RGBA transfer functions: piecewise linear over the normalised value range [0, 1].
///
/// JSON format (also accepted by `strata render --tf FILE`):
///   {
///     "range":  [lo, hi],                            // optional, in data values
///     "points": [ {"x": 0.20, "rgba": [r, g, b, a]}, // x in [0, 1], components in [0, 1]
///                 {"x": 0.35, "rgba": [1, 0.9, 0.8, 0.6]}, ... ]
///   }
/// A data value v maps to x = (v - lo) / (hi - lo), where [lo, hi] is "range" when given and the
/// volume's value range (TaVolume::value_min/value_max) otherwise. Points must be sorted by x
/// (non-decreasing); two points with the same x make a step, and the later point holds at that
/// x. Outside the first and last point the end colours hold. "rgba" is a straight (not
/// premultiplied) colour; "a" is the opacity of a segment one reference step long, the
/// reference step being one level-0 voxel (the smallest spacing), so a TF looks the same at any
/// sampling rate (opacity correction alpha' = 1 - (1 - alpha)^(step / reference)).
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace strata::render {

/// @brief Premultiplied (or straight, as documented at each use) RGBA in floats.
struct Rgbaf {
  float r = 0, g = 0, b = 0, a = 0;
};

/// @brief One control point of a transfer function.
struct TfPoint {
  double x = 0;
  std::array<float, 4> rgba{};  // straight colour, alpha per reference step
};

/// @brief Data value -> normalised TF coordinate x (scale 0 for an empty range).
struct ValueMapping {
  double lo = 0, hi = 1;
  double scale() const { return hi > lo ? 1.0 / (hi - lo) : 0.0; }
  double normalise(double v) const { return (v - lo) * scale(); }
};

/// @brief Opacity of a segment `ratio` reference steps long, for a TF opacity `alpha` per
/// reference step.
float correct_opacity(float alpha, double ratio);

/// @brief `size` entries at x = i / (size - 1); premultiplied colour, opacity corrected for `ratio`.
struct LookupTable {
  int size = 0;
  double ratio = 1;
  std::vector<Rgbaf> entries;
};

/// @brief Pre-integrated classification (Engel et al. 2001): entry [front * size + back] is the
/// premultiplied colour and opacity of a segment `ratio` reference steps long along which the
/// normalised value goes linearly from front/(size-1) to back/(size-1), with self-attenuation
/// inside the segment. Entries with front == back equal the opacity-corrected lookup table.
struct PreintegratedTable {
  int size = 0;
  double ratio = 1;
  std::vector<Rgbaf> entries;
};

/// @brief A transfer function: its points, optional value range, and the tables and visibility
/// tests the ray caster and the LOD selection read. Immutable once made.
class TransferFunction {
 public:
  /// @brief Throws Error when points are empty, unsorted or out of [0, 1], or range is not lo < hi.
  explicit TransferFunction(std::vector<TfPoint> points, std::optional<std::pair<double, double>> range = {});

  /// @brief The JSON form. `source` names the document in error messages (usually a file
  /// path); errors are FormatError(source, field, problem) with fields like "points[2].rgba".
  static TransferFunction from_json(const nlohmann::json& j, const std::string& source);
  /// @brief A JSON file; errors name the file.
  static TransferFunction load(const std::filesystem::path& path);
  /// @brief "grayscale", "ct" (alias "bone"), "mri", "fire"; throws Error listing the names otherwise.
  static TransferFunction preset(std::string_view name);
  /// @brief The preset names preset() accepts (without aliases).
  static std::span<const std::string_view> preset_names();
  /// @brief A preset name or a JSON file path (the CLI's --tf argument); throws
  /// ParameterError("preset_or_path") when it is neither.
  static TransferFunction from_argument(const std::string& preset_or_path);
  /// @brief True when `name` names a preset (preset() accepts it, "bone" included).
  static bool is_preset(std::string_view name);
  /// @brief The compact text form `v:r:g:b:a;v:r:g:b:a;...` (the viewer's `tf` parameter): at
  /// least two points, `v` in data units (non-decreasing, the first below the last; they set the
  /// TF's range), `r,g,b,a` in [0, 1] as in the JSON form. Never touches the filesystem.
  /// Throws ParameterError("text") naming the point and what was expected.
  static TransferFunction from_points_text(std::string_view text);
  /// @brief The JSON form (from_json reads it back).
  nlohmann::json to_json() const;

  const std::vector<TfPoint>& points() const { return points_; }
  const std::optional<std::pair<double, double>>& range() const { return range_; }
  /// @brief The TF's own range when set, else [volume_lo, volume_hi].
  ValueMapping mapping(double volume_lo, double volume_hi) const;

  /// @brief Straight RGBA at normalised x (clamped to the end points).
  Rgbaf evaluate(double x) const;
  /// @brief True when some x in [x_lo, x_hi] (normalised, closed) has non-zero opacity. Exact on
  /// the control points, so a brick whose [min, max] fails this test contributes nothing.
  bool visible(double x_lo, double x_hi) const;
  /// @brief Bit i set when the TF is non-zero somewhere in histogram bin i of 64 equal bins over
  /// [value_lo, value_hi] (the file's value range; bin 0 also takes values below, bin 63 values
  /// above, as the compressor bins them). A brick with (histogram & mask) == 0 is invisible.
  std::uint64_t visible_bins(double value_lo, double value_hi) const;

  /// @brief The post-classification table (LookupTable) of `size` entries for segments `ratio`
  /// reference steps long.
  LookupTable lookup_table(int size, double ratio) const;
  /// @brief The pre-integrated table (PreintegratedTable) of size^2 entries for segments `ratio`
  /// reference steps long.
  PreintegratedTable preintegrated_table(int size, double ratio) const;

 private:
  std::vector<TfPoint> points_;
  std::optional<std::pair<double, double>> range_;
  std::vector<std::pair<double, double>> visible_;  // closed intervals of x with alpha > 0 (may reach +-inf)
};

}  // namespace strata::render
