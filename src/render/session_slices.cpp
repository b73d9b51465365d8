// RenderSession: slices, voxel values and label colours (opening and frames are in
// render_session.cpp).
#include <algorithm>
#include <string>

#include "render/render_session_parts.hpp"
#include "strata/core/error.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/mixture/palette.hpp"

namespace strata::render {

namespace {

void check_slice(const RenderSession& session, const SliceSpec& spec) {
  if (spec.level < 0 || spec.level >= session.level_count())
    throw ParameterError("SliceSpec::level", "level " + std::to_string(spec.level) + " is not in 0.." +
                                                 std::to_string(session.level_count() - 1));
  (void)slice_box(session.dims(), spec.axis, spec.index);  // the level-0 index must lie inside
}

void check_voxel(const Extent& v, const Extent& dims) {
  if (v.x < 0 || v.y < 0 || v.z < 0 || v.x >= dims.x || v.y >= dims.y || v.z >= dims.z)
    throw ParameterError("voxel", "voxel " + v.to_string() + " is outside the volume " + dims.to_string());
}

// The box of a slice at its level (check_slice first).
Box level_slice_box(const RenderSession& session, const SliceSpec& spec) {
  return slice_box(session.level_dims(spec.level), spec.axis, spec.index >> spec.level);
}

template <class T>
Slice<T> empty_slice(const Box& box, SliceAxis axis) {
  Slice<T> out;
  std::tie(out.width, out.height) = slice_size(box, axis);
  out.values.resize(std::size_t(out.width) * std::size_t(out.height));
  return out;
}

std::uint8_t unit_byte(float v) { return std::uint8_t(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f); }

}  // namespace

void RenderSession::Scalar::prefetch_slice_neighbours(const SliceSpec& spec) {
  const Extent& dims = volume.geometry().level(spec.level).dims;
  const std::int64_t core = volume.geometry().layout().core();
  const std::int64_t extent = spec.axis == SliceAxis::x ? dims.x : spec.axis == SliceAxis::y ? dims.y : dims.z;
  const std::int64_t index = spec.index >> spec.level;
  lod::Selection cut;
  // A slice one core width away lies in the neighbouring layer (clamped: at the volume's edge
  // it is the slice's own layer, whose bricks are resident and not queued again).
  for (const std::int64_t neighbour : {index + core, index - core})
    for_each_brick_in(spec.level, slice_box(dims, spec.axis, std::clamp<std::int64_t>(neighbour, 0, extent - 1)),
                      [&](const lod::CutBrick& brick) { cut.bricks.push_back(brick); });
  provider.prefetch(cut, spec.rank > 0 ? spec.rank : volume.rank());
}

std::vector<std::uint32_t> RenderSession::Labels::slice_nodes(const SliceSpec& spec, std::pair<int, int>& size) const {
  const Box box = slice_box(labels.level_dims(spec.level), spec.axis, spec.index >> spec.level);
  size = slice_size(box, spec.axis);
  std::vector<std::uint32_t> ids(std::size_t(box.voxel_count()));
  labels.decode_box(spec.level, box, ids);
  return ids;
}

Slice<float> RenderSession::value_slice(const SliceSpec& spec) {
  if (labels_) throw Error(path_.string() + ": a label volume has no sample values; ask for label slices");
  check_slice(*this, spec);
  const Box box = level_slice_box(*this, spec);
  Slice<float> out = empty_slice<float>(box, spec.axis);
  auto put = [&](std::int64_t x, std::int64_t y, std::int64_t z, float v) {
    out.values[slice_offset(box, spec.axis, x, y, z)] = v;
  };
  if (scalar_) {
    scalar_->visit_box(spec.level, box, spec.rank, put);
    scalar_->prefetch_slice_neighbours(spec);
    return out;
  }
  const auto v = plain_->volume.view<float>();
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
      for (std::int64_t x = box.lo.x; x < box.hi.x; ++x) put(x, y, z, v(x, y, z));
  return out;
}

Slice<std::int64_t> RenderSession::label_slice(const SliceSpec& spec) {
  Labels& l = require_labels();
  check_slice(*this, spec);
  Slice<std::int64_t> out;
  std::pair<int, int> size;
  const std::vector<std::uint32_t> ids = l.slice_nodes(spec, size);
  std::tie(out.width, out.height) = size;
  // Level-0 ids are the sources themselves; coarser nodes map to their dominant source.
  if (spec.level > 0 && l.dominant.empty()) l.dominant = l.labels.dominant_sources();
  const mixture::LabelMap& map = l.labels.label_map();
  out.values.reserve(ids.size());
  for (std::uint32_t id : ids) out.values.push_back(map.value(spec.level > 0 ? l.dominant[id] : id));
  return out;
}

Slice<float> RenderSession::label_fraction_slice(const SliceSpec& spec, std::int64_t label) {
  Labels& l = require_labels();
  check_slice(*this, spec);
  if (l.fraction_label != label) {
    l.fractions = l.labels.label_fractions(label);
    l.fraction_label = label;
  }
  Slice<float> out;
  std::pair<int, int> size;
  const std::vector<std::uint32_t> ids = l.slice_nodes(spec, size);
  std::tie(out.width, out.height) = size;
  out.values.reserve(ids.size());
  for (std::uint32_t id : ids) out.values.push_back(l.fractions[id]);
  return out;
}

Image RenderSession::palette_slice(const SliceSpec& spec) {
  Labels& l = require_labels();
  check_slice(*this, spec);
  if (l.slice_palette.empty()) {
    // Every visible label opaque: a slice shows which labels cover a voxel, not how much of
    // the 3D view's opacity they carry.
    std::vector<float> sources = l.colors.premultiplied_sources(l.labels.label_map());
    for (std::size_t i = 0; i + 3 < sources.size(); i += 4) {
      const float a = sources[i + 3];
      if (a <= 0) continue;
      for (std::size_t c = 0; c < 3; ++c) sources[i + c] /= a;
      sources[i + 3] = 1;
    }
    l.slice_palette = mixture::propagate_palette(l.labels.graph(), l.labels.schedule(), sources, 4);
  }
  std::pair<int, int> size;
  const std::vector<std::uint32_t> ids = l.slice_nodes(spec, size);
  // Straight alpha: the colour of the visible labels a voxel holds, and how much of it they
  // cover, so an overlay shows the scalar slice through background and hidden labels (and a
  // label coloured black stays visible).
  Image image(size.first, size.second);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const float* c = l.slice_palette.data() + std::size_t(ids[i]) * 4;
    const float a = c[3];
    image.pixels()[i] = a > 0 ? Rgba8{unit_byte(c[0] / a), unit_byte(c[1] / a), unit_byte(c[2] / a), unit_byte(a)}
                              : Rgba8{0, 0, 0, 0};
  }
  return image;
}

double RenderSession::value_at(const Extent& voxel, int rank) {
  if (labels_) throw Error(path_.string() + ": a label volume has no sample values; ask for the label");
  check_voxel(voxel, dims());
  if (plain_) return plain_->volume.view<float>()(voxel.x, voxel.y, voxel.z);
  double value = 0;
  scalar_->visit_box(0, {voxel, {voxel.x + 1, voxel.y + 1, voxel.z + 1}}, rank,
                     [&](std::int64_t, std::int64_t, std::int64_t, float v) { value = v; });
  return value;
}

std::int64_t RenderSession::label_at(const Extent& voxel) const {
  const mixture::EncodedLabels& l = labels();
  check_voxel(voxel, dims());
  return l.label_map().value(l.node_at(0, voxel.x, voxel.y, voxel.z));
}

double RenderSession::set_label_colors(LabelColorMap colors) {
  Labels& l = require_labels();
  const auto t0 = SteadyClock::now();
  l.colors = colors;
  l.scene.set_color_map(std::move(colors));
  l.slice_palette.clear();
  // Propagate now rather than at the next frame, so the caller sees what it cost.
  l.scene.prepare(l.scene.level_count() - 1, false);
  return ms_since(t0);
}

RenderSession::Labels& RenderSession::require_labels() const {
  if (!labels_)
    throw Error(path_.string() + ": not a label volume (this is a " + std::string(dataset_kind_name(kind())) + " volume)");
  return *labels_;
}

const mixture::EncodedLabels& RenderSession::labels() const { return require_labels().labels; }

}  // namespace strata::render
