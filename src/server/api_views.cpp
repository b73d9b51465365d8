// GET /api/datasets/{id}/slice and /value: 2D views and voxel probes.
#include <bit>
#include <cstring>
#include <limits>

#include <fmt/format.h>

#include "server/api_detail.hpp"

namespace strata::server::detail {

namespace {

static_assert(std::endian::native == std::endian::little, "raw slices are sent as the host's little-endian bytes");

using render::DatasetKind;

struct SliceRequest {
  render::SliceSpec spec;
  bool raw = false;
  std::optional<std::pair<double, double>> window;
  std::shared_ptr<const render::TransferFunction> tf;
  std::optional<std::int64_t> label;
};

std::int64_t axis_extent(const Extent& d, render::SliceAxis axis) {
  return axis == render::SliceAxis::x ? d.x : axis == render::SliceAxis::y ? d.y : d.z;
}

SliceRequest parse_slice(const Dataset& d, const HttpRequest& r) {
  const Params p(r, {"axis", "index", "level", "zoom", "rank", "window", "tf", "label", "format"});
  SliceRequest s;
  const std::string axis = p.choice("axis", {"x", "y", "z"}, "");
  if (axis.empty()) bad_parameter("axis", "required (x, y or z)");
  s.spec.axis = axis == "x" ? render::SliceAxis::x : axis == "y" ? render::SliceAxis::y : render::SliceAxis::z;
  s.spec.index = p.required_integer("index", 0, axis_extent(d.session->dims(), s.spec.axis) - 1);
  const int levels = d.session->level_count();
  if (p.has("level") && p.has("zoom")) bad_parameter("zoom", "give level or zoom, not both");
  s.spec.level = p.has("level") ? int(*p.integer("level", 0, levels - 1))
                                : render::slice_level_for_zoom(p.number("zoom", {0, 1e6, true}, 1.0), levels);
  s.spec.rank = parse_rank(p, d);
  if (p.has("window") && p.has("tf")) bad_parameter("tf", "give window or tf, not both");
  if (const auto window = p.numbers("window", 2)) {
    require_kind(d, {DatasetKind::scalar, DatasetKind::plain}, "window");
    if (!((*window)[0] < (*window)[1])) bad_parameter("window", "expected lo,hi with lo < hi");
    s.window = std::pair{(*window)[0], (*window)[1]};
  }
  if (const auto tf = p.text("tf")) {
    require_kind(d, {DatasetKind::scalar, DatasetKind::plain}, "tf");
    s.tf = parse_tf(*tf);
  }
  if (p.has("label")) {
    require_kind(d, {DatasetKind::labels}, "label");
    s.label = *p.integer("label", std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::max());
    if (!d.session->has_label(*s.label)) bad_parameter("label", fmt::format("label {} does not occur in dataset {}", *s.label, d.id));
  }
  s.raw = p.choice("format", {"png", "raw"}, "png") == "raw";
  return s;
}

template <class T>
HttpResponse raw_response(const std::vector<T>& values) {
  HttpResponse r;
  r.content_type = "application/octet-stream";
  r.body.resize(values.size() * sizeof(T));
  std::memcpy(r.body.data(), values.data(), r.body.size());
  return r;
}

HttpResponse png_response(const render::Image& image) { return bytes_response("image/png", render::encode_png(image)); }

// Grey slices go out as 8-bit grey PNGs: a quarter of the bytes of RGBA to filter and deflate.
HttpResponse grey_png_response(const render::Slice<float>& slice, double lo, double hi) {
  return bytes_response("image/png", render::encode_grey_png(render::grey_levels(slice, lo, hi), slice.width, slice.height));
}

// Scalar and plain data: float32 values, or grey through the window (default: the value range),
// or colours through a transfer function.
HttpResponse value_slice(render::RenderSession& session, const SliceRequest& s, int& width, int& height) {
  const render::Slice<float> slice = session.value_slice(s.spec);
  width = slice.width;
  height = slice.height;
  if (s.raw) return raw_response(slice.values);
  const auto [lo, hi] = session.value_range();
  if (s.tf) return png_response(render::tf_image(slice, *s.tf, lo, hi));
  const auto window = s.window.value_or(std::pair{lo, hi > lo ? hi : lo + 1});
  return grey_png_response(slice, window.first, window.second);
}

// Label data: uint32 labels (dominant at coarse levels) or palette colours; with `label`, that
// label's fraction as float32 or grey.
HttpResponse label_slice(render::RenderSession& session, const SliceRequest& s, int& width, int& height) {
  if (s.label) {
    const render::Slice<float> slice = session.label_fraction_slice(s.spec, *s.label);
    width = slice.width;
    height = slice.height;
    return s.raw ? raw_response(slice.values) : grey_png_response(slice, 0, 1);
  }
  if (!s.raw) {
    const render::Image image = session.palette_slice(s.spec);
    width = image.width();
    height = image.height();
    return png_response(image);
  }
  const render::Slice<std::int64_t> slice = session.label_slice(s.spec);
  width = slice.width;
  height = slice.height;
  std::vector<std::uint32_t> labels(slice.values.begin(), slice.values.end());
  return raw_response(labels);
}

}  // namespace

HttpResponse slice_image(Dataset& d, const HttpRequest& r) {
  const SliceRequest s = parse_slice(d, r);
  int width = 0, height = 0;
  HttpResponse response;
  {
    std::lock_guard lock(d.mutex);
    response = d.session->kind() == DatasetKind::labels ? label_slice(*d.session, s, width, height)
                                                        : value_slice(*d.session, s, width, height);
  }
  response.set_header("X-Strata-Level", std::to_string(s.spec.level));
  response.set_header("X-Strata-Dims", fmt::format("{},{}", width, height));
  return response;
}

HttpResponse voxel_value(Dataset& d, const HttpRequest& r) {
  const Params p(r, {"x", "y", "z", "rank"});
  const Extent dims = d.session->dims();
  const Extent voxel{p.required_integer("x", 0, dims.x - 1), p.required_integer("y", 0, dims.y - 1),
                     p.required_integer("z", 0, dims.z - 1)};
  const int rank = parse_rank(p, d);
  std::lock_guard lock(d.mutex);
  if (d.session->kind() == DatasetKind::labels) return json_response({{"label", d.session->label_at(voxel)}});
  return json_response({{"value", d.session->value_at(voxel, rank)}});
}

}  // namespace strata::server::detail
