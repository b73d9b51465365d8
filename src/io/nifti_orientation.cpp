#include "io/nifti_orientation.hpp"

#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "strata/core/error.hpp"

namespace strata::io::detail {

namespace {

// NIFTI_UNITS_* of xyzt_units' spatial bits (nifti1.h).
constexpr int kUnitsMeter = 1, kUnitsMm = 2, kUnitsMicron = 3, kSpatialUnitMask = 0x07;

std::string unit_of(int xyzt_units) {
  switch (xyzt_units & kSpatialUnitMask) {
    case kUnitsMeter: return "m";
    case kUnitsMm: return "mm";
    case kUnitsMicron: return "um";
    default: return {};
  }
}

int units_code(const std::string& unit) {
  if (unit == "m") return kUnitsMeter;
  if (unit == "mm") return kUnitsMm;
  if (unit == "um") return kUnitsMicron;
  return 0;
}

// nifti1.h METHOD 2: R from the unit quaternion (a, b, c, d), a = sqrt(1 - b^2 - c^2 - d^2),
// columns scaled by the voxel size and the third by qfac.
Matrix4 qform_affine(const NiftiTransforms& t, const Spacing& spacing) {
  const auto [b, c, d] = t.quatern;
  const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
  const Matrix3 r{{{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
                   {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
                   {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}}};
  const std::array<double, 3> s{spacing.x, spacing.y, spacing.z * (t.qfac < 0 ? -1.0 : 1.0)};
  Matrix4 m{};
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) m[row][col] = r[row][col] * s[col];
    m[row][3] = t.qoffset[row];
  }
  m[3] = {0, 0, 0, 1};
  return m;
}

Matrix4 sform_affine(const NiftiTransforms& t) {
  Matrix4 m{};
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 4; ++col) m[row][col] = t.srow[row][col];
  m[3] = {0, 0, 0, 1};
  return m;
}

// The affine the header places the volume by (sform first, as nibabel does), if any.
std::optional<Matrix4> header_affine(const NiftiTransforms& t, const Spacing& spacing) {
  if (t.sform_code > 0) return sform_affine(t);
  if (t.qform_code > 0) return qform_affine(t, spacing);
  return std::nullopt;
}

// The unit quaternion (b, c, d with a >= 0) of rotation `r`, from its largest diagonal term
// for stability.
std::array<double, 3> quaternion_of(const Matrix3& r) {
  double a, b, c, d;
  const double trace = 1.0 + r[0][0] + r[1][1] + r[2][2];
  if (trace > 0.5) {
    a = 0.5 * std::sqrt(trace);
    b = 0.25 * (r[2][1] - r[1][2]) / a;
    c = 0.25 * (r[0][2] - r[2][0]) / a;
    d = 0.25 * (r[1][0] - r[0][1]) / a;
  } else if (const double xd = 1.0 + r[0][0] - (r[1][1] + r[2][2]); xd > 1.0) {
    b = 0.5 * std::sqrt(xd);
    c = 0.25 * (r[0][1] + r[1][0]) / b;
    d = 0.25 * (r[0][2] + r[2][0]) / b;
    a = 0.25 * (r[2][1] - r[1][2]) / b;
  } else if (const double yd = 1.0 + r[1][1] - (r[0][0] + r[2][2]); yd > 1.0) {
    c = 0.5 * std::sqrt(yd);
    b = 0.25 * (r[0][1] + r[1][0]) / c;
    d = 0.25 * (r[1][2] + r[2][1]) / c;
    a = 0.25 * (r[0][2] - r[2][0]) / c;
  } else {
    d = 0.5 * std::sqrt(1.0 + r[2][2] - (r[0][0] + r[1][1]));
    b = 0.25 * (r[0][2] + r[2][0]) / d;
    c = 0.25 * (r[1][2] + r[2][1]) / d;
    a = 0.25 * (r[1][0] - r[0][1]) / d;
  }
  if (a < 0) return {-b, -c, -d};
  return {b, c, d};
}

double determinant(const Matrix3& m) {
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

// --- format_fields text: every double in the shortest form that reads back exactly ----------

constexpr const char* kQformCode = "nifti.qform_code";
constexpr const char* kSformCode = "nifti.sform_code";
constexpr const char* kQuatern = "nifti.quatern_bcd";
constexpr const char* kQoffset = "nifti.qoffset_xyz";
constexpr const char* kQfac = "nifti.qfac";
constexpr const char* kSrow = "nifti.srow_xyz";
constexpr const char* kXyztUnits = "nifti.xyzt_units";

template <class Range>
std::string numbers_text(const Range& values) {
  return fmt::format("{}", fmt::join(values, " "));
}

std::optional<std::vector<double>> numbers_of(const std::string& text, std::size_t count) {
  std::istringstream in(text);
  std::vector<double> values;
  double v = 0;
  while (in >> v) values.push_back(v);
  if (!in.eof() || values.size() != count) return std::nullopt;
  return values;
}

// The transforms kept at reading; nullopt when absent or not all there (then the writer derives
// them from the geometry instead).
std::optional<NiftiTransforms> kept_transforms(const std::map<std::string, std::string>& fields) {
  const auto field = [&](const char* key, std::size_t count) -> std::optional<std::vector<double>> {
    const auto it = fields.find(key);
    if (it == fields.end()) return std::nullopt;
    return numbers_of(it->second, count);
  };
  const auto qcode = field(kQformCode, 1), scode = field(kSformCode, 1), quatern = field(kQuatern, 3),
             qoffset = field(kQoffset, 3), qfac = field(kQfac, 1), srow = field(kSrow, 12), units = field(kXyztUnits, 1);
  if (!qcode || !scode || !quatern || !qoffset || !qfac || !srow || !units) return std::nullopt;
  NiftiTransforms t;
  t.qform_code = int((*qcode)[0]);
  t.sform_code = int((*scode)[0]);
  t.quatern = {(*quatern)[0], (*quatern)[1], (*quatern)[2]};
  t.qoffset = {(*qoffset)[0], (*qoffset)[1], (*qoffset)[2]};
  t.qfac = (*qfac)[0];
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 4; ++col) t.srow[row][col] = (*srow)[std::size_t(row * 4 + col)];
  t.xyzt_units = int((*units)[0]);
  return t;
}

// Finite, with three axes of non-zero length: an affine a volume can be placed by.
bool well_formed(const Matrix4& m) {
  for (const auto& row : m)
    for (double v : row)
      if (!std::isfinite(v)) return false;
  for (int c = 0; c < 3; ++c)
    if (m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c] == 0.0) return false;
  return true;
}

bool places_at_identity(const Geometry& g) { return g.origin == Vector3{0, 0, 0} && g.direction == kIdentity3; }

}  // namespace

void keep_nifti_transforms(const NiftiTransforms& t, std::map<std::string, std::string>& fields) {
  fields[kQformCode] = std::to_string(t.qform_code);
  fields[kSformCode] = std::to_string(t.sform_code);
  fields[kQuatern] = numbers_text(t.quatern);
  fields[kQoffset] = numbers_text(t.qoffset);
  fields[kQfac] = numbers_text(std::array<double, 1>{t.qfac});
  std::vector<double> srow;
  for (const auto& row : t.srow) srow.insert(srow.end(), row.begin(), row.end());
  fields[kSrow] = numbers_text(srow);
  fields[kXyztUnits] = std::to_string(t.xyzt_units);
}

Geometry nifti_geometry(const NiftiTransforms& t, Spacing& spacing, const std::string& file) {
  Geometry g;
  g.unit = unit_of(t.xyzt_units);
  keep_nifti_transforms(t, g.format_fields);
  // A degenerate sform (zero or non-finite rows) falls back to the qform, then to no placement,
  // as nibabel does, rather than making the samples unreadable.
  std::optional<Matrix4> affine = header_affine(t, spacing);
  if (affine && t.sform_code > 0 && !well_formed(*affine)) affine = t.qform_code > 0 ? std::optional(qform_affine(t, spacing)) : std::nullopt;
  if (!affine || !well_formed(*affine)) return g;
  Spacing lengths;
  const Geometry placed = geometry_from_affine(*affine, lengths, WorldSpace::ras, file);
  g.origin = placed.origin;
  g.direction = placed.direction;
  g.space = WorldSpace::ras;
  // pixdim is the voxel size every tool shows; the sform's column lengths only override it when
  // the two disagree beyond float rounding, since the placement must be the header's.
  const auto differs = [](double a, double b) { return std::abs(a - b) > 1e-5 * std::max(std::abs(a), std::abs(b)); };
  if (differs(lengths.x, spacing.x) || differs(lengths.y, spacing.y) || differs(lengths.z, spacing.z)) spacing = lengths;
  return g;
}

NiftiTransforms nifti_transforms_for(const Geometry& geometry, const Spacing& spacing) {
  const Geometry ras = in_world_space(geometry, WorldSpace::ras);
  const Matrix4 current = index_to_world(ras, spacing);
  if (const auto kept = kept_transforms(geometry.format_fields)) {
    const std::optional<Matrix4> kept_affine = header_affine(*kept, spacing);
    if (kept_affine ? affines_match(*kept_affine, current, 1e-5) : places_at_identity(ras)) return *kept;
  }
  NiftiTransforms t;
  t.xyzt_units = units_code(canonical_length_unit(geometry.unit));
  if (places_at_identity(ras) && ras.space == WorldSpace::unspecified) return t;  // nothing to claim
  const int code = ras.space == WorldSpace::unspecified ? 2 : 1;  // aligned anat / scanner anat
  t.qform_code = t.sform_code = code;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 4; ++col) t.srow[row][col] = current[row][col];
  Matrix3 rotation = ras.direction;
  if (determinant(rotation) < 0) {  // a left-handed frame: qfac flips the third axis
    t.qfac = -1.0;
    for (auto& row : rotation) row[2] = -row[2];
  }
  t.quatern = quaternion_of(rotation);
  t.qoffset = ras.origin;
  return t;
}

}  // namespace strata::io::detail
