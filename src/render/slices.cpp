#include "strata/render/slices.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "strata/core/error.hpp"

namespace strata::render {

std::string_view slice_axis_name(SliceAxis axis) {
  switch (axis) {
    case SliceAxis::x: return "x";
    case SliceAxis::y: return "y";
    case SliceAxis::z: break;
  }
  return "z";
}

Box slice_box(const Extent& d, SliceAxis axis, std::int64_t i) {
  const std::int64_t extent = axis == SliceAxis::x ? d.x : axis == SliceAxis::y ? d.y : d.z;
  if (i < 0 || i >= extent)
    throw ParameterError("SliceSpec::index", "slice " + std::to_string(i) + " along " + std::string(slice_axis_name(axis)) +
                                                 " is outside 0.." + std::to_string(extent - 1));
  Box box = Box::whole(d);
  if (axis == SliceAxis::x) box.lo.x = i, box.hi.x = i + 1;
  if (axis == SliceAxis::y) box.lo.y = i, box.hi.y = i + 1;
  if (axis == SliceAxis::z) box.lo.z = i, box.hi.z = i + 1;
  return box;
}

std::pair<int, int> slice_size(const Box& box, SliceAxis axis) {
  const Extent s = box.size();
  if (axis == SliceAxis::x) return {int(s.y), int(s.z)};
  if (axis == SliceAxis::y) return {int(s.x), int(s.z)};
  return {int(s.x), int(s.y)};
}

int slice_level_for_zoom(double zoom, int level_count) {
  if (!(std::isfinite(zoom) && zoom > 0)) throw ParameterError("zoom", "must be a positive number");
  const double level = std::round(-std::log2(zoom));
  return int(std::clamp(level, 0.0, double(std::max(0, level_count - 1))));
}

namespace {

std::uint8_t byte_of(double unit) { return std::uint8_t(std::lround(std::clamp(unit, 0.0, 1.0) * 255.0)); }

}  // namespace

std::vector<std::uint8_t> grey_levels(const Slice<float>& slice, double lo, double hi) {
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi)) throw ParameterError("window", "expected lo < hi, both finite");
  std::vector<std::uint8_t> grey(slice.values.size());
  const double scale = 1.0 / (hi - lo);
  for (std::size_t i = 0; i < slice.values.size(); ++i) grey[i] = byte_of((slice.values[i] - lo) * scale);
  return grey;
}


Image tf_image(const Slice<float>& slice, const TransferFunction& tf, double value_lo, double value_hi) {
  Image image(slice.width, slice.height);
  const ValueMapping mapping = tf.mapping(value_lo, value_hi);
  for (std::size_t i = 0; i < slice.values.size(); ++i) {
    const Rgbaf c = tf.evaluate(mapping.normalise(slice.values[i]));
    image.pixels()[i] = c.a > 0 ? Rgba8{byte_of(c.r), byte_of(c.g), byte_of(c.b), 255} : Rgba8{0, 0, 0, 255};
  }
  return image;
}

}  // namespace strata::render
