#pragma once
/// @file
/// @brief Where a volume's voxels lie in space: origin, direction cosines, world space and length
/// unit, read from every format that has them, kept in the `.strata` metadata and written back.
///
/// The voxel of index (i, j, k) has its centre at
///     world = origin + direction * diag(spacing) * (i, j, k)
/// in the volume's world space. The spacing stays in VolumeInfo (it predates this type and every
/// kernel uses it); Geometry adds the rest of the index-to-world affine.
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>

namespace strata {

using Vector3 = std::array<double, 3>;
/// Row-major: m[row][column].
using Matrix3 = std::array<Vector3, 3>;
/// Row-major 4x4 homogeneous transform.
using Matrix4 = std::array<std::array<double, 4>, 4>;

struct Spacing;

/// @brief The anatomical meaning of the world axes. NIfTI is RAS+ (x to the right, y anterior, z
/// superior); DICOM, ITK and most NRRD files are LPS+. Microscopy, simulation and EM volumes have
/// a physical frame without anatomy: `unspecified`.
enum class WorldSpace : unsigned char { unspecified, ras, lps };

/// @brief "unspecified", "RAS" or "LPS".
std::string_view world_space_name(WorldSpace space);
/// @brief The inverse of world_space_name (case-insensitive); throws Error naming `context`.
WorldSpace parse_world_space(std::string_view name, std::string_view context);

constexpr Matrix3 kIdentity3{{{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}};

/// @brief A volume's placement in space beyond its voxel spacing.
struct Geometry {
  /// World position of the centre of voxel (0, 0, 0), in `unit`.
  Vector3 origin{0.0, 0.0, 0.0};
  /// Column c is the unit vector of index axis c (i, j, k) in world space.
  Matrix3 direction = kIdentity3;
  WorldSpace space = WorldSpace::unspecified;
  /// Length unit of origin and spacing: "mm", "um", "nm", "angstrom", "m", ... or "" (unknown).
  std::string unit;
  /// Header fields of the format the volume was read from, kept so that the writer of the same
  /// format restores them verbatim while the geometry still matches them (NIfTI's qform and sform
  /// with their codes: "nifti.qform_code", ...). Keys are "<format>.<field>"; values are text.
  std::map<std::string, std::string> format_fields;

  /// @brief Whether this says nothing beyond the defaults (identity, origin 0, no unit).
  bool is_default() const;
  bool operator==(const Geometry&) const = default;
};

/// @brief The index-to-world affine of `geometry` with `spacing`, in geometry.space.
Matrix4 index_to_world(const Geometry& geometry, const Spacing& spacing);

/// @brief Splits an index-to-world affine into spacing (column norms) and geometry (unit columns,
/// translation). Throws Error naming `context` when a column is zero or not finite.
Geometry geometry_from_affine(const Matrix4& affine, Spacing& spacing, WorldSpace space, std::string_view context);

/// @brief `geometry` expressed in `space`: RAS and LPS differ by the signs of x and y. Unchanged
/// when either space is unspecified.
Geometry in_world_space(const Geometry& geometry, WorldSpace space);

/// @brief The geometry of level `level` of a mip pyramid whose voxel of level L covers the 2^L
/// voxels [i 2^L, (i + 1) 2^L) of level 0 along each axis: same direction and space, origin
/// moved to the centre of the first such block. Format fields are dropped unless level is 0.
Geometry level_geometry(const Geometry& level0, const Spacing& level0_spacing, int level);

/// @brief The geometry of the box starting at voxel `first` of a volume of `geometry` and
/// `spacing`: origin moved to that voxel's centre. Format fields are dropped unless `first` is 0.
Geometry box_geometry(const Geometry& geometry, const Spacing& spacing, const std::array<std::int64_t, 3>& first);

/// @brief Whether two affines agree to `tolerance` relative to the largest entry of either
/// (format writers use it to decide whether kept header fields still describe the volume).
bool affines_match(const Matrix4& a, const Matrix4& b, double tolerance = 1e-6);

/// @brief Whether a length unit name is one we know ("mm", "um", "nm", "angstrom", "m", "cm",
/// "micron", "micrometer", ...); canonical spelling of it, or "" when unknown.
std::string canonical_length_unit(std::string_view unit);

/// @brief Metres per `unit` (a canonical_length_unit name): 1e-3 for "mm", 1e-10 for
/// "angstrom"; 0 for an unknown or empty unit.
double metres_per_unit(std::string_view unit);

}  // namespace strata
