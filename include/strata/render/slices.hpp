#pragma once
/// @file
/// @brief Axis-aligned slices of a volume level: their geometry, the level that suits a zoom,
/// and their display as images (what the viewer's three slice views show).
///
/// Orientation: a slice across `axis` holds u along the first remaining axis and v along the
/// second (z: u = x, v = y; y: u = x, v = z; x: u = y, v = z). Values are stored row by row,
/// v = 0 first, and image row 0 is v = 0 (a viewer flips the rows if it wants v up).
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "strata/core/extent.hpp"
#include "strata/render/image.hpp"
#include "strata/render/transfer_function.hpp"

namespace strata::render {

/// @brief The axis a slice is perpendicular to.
enum class SliceAxis : std::uint8_t { x, y, z };
/// @brief "x", "y" or "z".
std::string_view slice_axis_name(SliceAxis axis);

/// @brief Which slice: `index` is a level-0 voxel along `axis`; level `level` shows its level
/// voxel index >> level. `rank` is the reconstruction rank of TA files (0 = stored rank).
struct SliceSpec {
  SliceAxis axis = SliceAxis::z;
  std::int64_t index = 0;
  int level = 0;
  int rank = 0;
};

/// @brief The values of one slice, `width` (u) by `height` (v), row by row.
template <class T>
struct Slice {
  int width = 0, height = 0;
  std::vector<T> values;
};

/// @brief The voxels of `level_dims` a slice covers: one voxel thick along the axis at
/// `level_index`. Throws ParameterError("SliceSpec::index") when level_index is outside.
Box slice_box(const Extent& level_dims, SliceAxis axis, std::int64_t level_index);
/// @brief Position in the slice's values of the voxel (x, y, z) of `box` (a slice_box).
inline std::size_t slice_offset(const Box& box, SliceAxis axis, std::int64_t x, std::int64_t y, std::int64_t z) {
  const Extent s = box.size();
  switch (axis) {
    case SliceAxis::x: return std::size_t((z - box.lo.z) * s.y + (y - box.lo.y));
    case SliceAxis::y: return std::size_t((z - box.lo.z) * s.x + (x - box.lo.x));
    case SliceAxis::z: break;
  }
  return std::size_t((y - box.lo.y) * s.x + (x - box.lo.x));
}
/// @brief Width and height of a slice over `box`.
std::pair<int, int> slice_size(const Box& box, SliceAxis axis);

/// @brief The level whose voxel best matches `zoom` screen pixels per level-0 voxel: a level-l
/// voxel spans zoom 2^l pixels, so l = round(-log2 zoom), clamped to 0..level_count-1.
/// Throws ParameterError("zoom") unless zoom is finite and positive.
int slice_level_for_zoom(double zoom, int level_count);

/// @brief Grey levels, one byte per voxel in slice order: [lo, hi] maps linearly to 0..255,
/// clamped. Requires lo < hi (ParameterError("window") otherwise).
std::vector<std::uint8_t> grey_levels(const Slice<float>& slice, double lo, double hi);
/// @brief Colour image through a transfer function (value mapping as for rendering over
/// [value_lo, value_hi] unless the TF has its own range): the TF's straight colour where its
/// opacity is positive, black where it is transparent; opaque.
Image tf_image(const Slice<float>& slice, const TransferFunction& tf, double value_lo, double value_hi);

}  // namespace strata::render
