#pragma once
// NIfTI's two orientations (nifti1.h "METHOD 2" qform: a rotation quaternion, an offset and the
// qfac sign; "METHOD 3" sform: a general 3x4 affine) and their codes, mapped to and from a
// volume's Geometry. Reading prefers the sform, as nibabel, FSL and ITK do; the fields as read are
// kept in Geometry::format_fields so a volume written back to NIfTI carries them bit for bit
// while its placement is unchanged.
#include <array>
#include <map>
#include <string>

#include "strata/core/geometry.hpp"
#include "strata/core/volume.hpp"

namespace strata::io::detail {

/// @brief The orientation fields of a NIfTI header (both versions), in header units: RAS+ world
/// millimetres (or the unit of xyzt_units).
struct NiftiTransforms {
  int qform_code = 0, sform_code = 0;
  std::array<double, 3> quatern{0.0, 0.0, 0.0};  // b, c, d
  std::array<double, 3> qoffset{0.0, 0.0, 0.0};
  double qfac = 1.0;  // pixdim[0]: -1 flips the third axis
  std::array<std::array<double, 4>, 3> srow{};
  int xyzt_units = 0;  // NIFTI_UNITS_*: spatial bits 0-2, temporal 3-5
  bool operator==(const NiftiTransforms&) const = default;
};

/// @brief The geometry the header describes: the sform when sform_code > 0, else the qform when
/// qform_code > 0, else none (identity, origin 0). `spacing` comes in as pixdim[1..3] and is
/// replaced by the affine's column lengths only when they disagree with it (a header whose
/// pixdim was not kept in step with its sform), so the placement is always the header's. A
/// degenerate sform (zero or non-finite) falls back to the qform, and a degenerate qform to no
/// placement, as nibabel does: the samples stay readable. `file` names the file in errors.
Geometry nifti_geometry(const NiftiTransforms& t, Spacing& spacing, const std::string& file);

/// @brief The fields to write for `geometry` and `spacing`: the ones kept at reading
/// (format_fields) when they still describe this placement, else a qform and sform made from it
/// (codes 1 when the world space is RAS or LPS, 2 when unspecified; 0 for a default geometry).
NiftiTransforms nifti_transforms_for(const Geometry& geometry, const Spacing& spacing);

/// @brief `t` as Geometry::format_fields entries ("nifti.qform_code", ...), added to `fields`.
void keep_nifti_transforms(const NiftiTransforms& t, std::map<std::string, std::string>& fields);

}  // namespace strata::io::detail
