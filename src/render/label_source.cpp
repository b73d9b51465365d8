// LabelSource: a label file opened for viewing. Frames and palette slices in the colours
// propagated through the Mixture Graph, label and fraction slices from the decoded node ids.
#include <algorithm>
#include <string>

#include "render/render_source_kinds.hpp"
#include "strata/core/error.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/mixture/palette.hpp"

namespace strata::render {

namespace {

std::uint8_t unit_byte(float v) { return std::uint8_t(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f); }

}  // namespace

LabelSource::LabelSource(std::filesystem::path path, std::unique_ptr<store::ContainerReader> input)
    : RenderSource(std::move(path)), labels_(std::move(input)), scene_(labels_, LabelColorMap{}) {
  if (labels_.has_normals()) normals_ = std::make_unique<LabelShading>(labels_.open_normals());
  if (const auto names = labels_.metadata().find("label_names"); names != labels_.metadata().end())
    names_ = mixture::label_names_from_json(*names, this->path().string());
}

std::pair<double, double> LabelSource::value_range() const {
  const auto values = labels_.label_map().values();
  return values.empty() ? std::pair{0.0, 0.0} : std::pair{double(values.front()), double(values.back())};
}

// Voxels of the coarsest level at most 64 wide whose footprint holds any label but 0.
double LabelSource::frame_radius() const {
  const Spacing s = labels_.spacing();
  const Extent d0 = labels_.level_dims(0);
  FrameSphere sphere(d0, s);
  const std::optional<std::uint32_t> background = labels_.label_map().id_of(0);
  if (!background) {
    sphere.add_box({0, 0, 0}, {double(d0.x) * s.x, double(d0.y) * s.y, double(d0.z) * s.z});
    return sphere.rounded();
  }
  const int level = std::min(frame_level(d0), labels_.level_count() - 1);
  const Extent d = labels_.level_dims(level);
  std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()));
  labels_.decode_box(level, Box::whole(d), ids);
  const std::vector<float> background_share = labels_.label_fractions(0);
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x)
        if (background_share[ids[std::size_t((z * d.y + y) * d.x + x)]] < 1.0f) sphere.add_cell(d0, s, level, x, y, z);
  return sphere.rounded();
}

Image LabelSource::frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
                         nlohmann::json& stats) {
  LabelRenderOptions options;
  options.lod_bias = settings.lod_bias;
  options.step = settings.step;
  options.shading = settings.shading;
  // Smooth boundaries cost several times a trilinear sample where labels meet: still frames
  // have them, frames taken while the camera moves keep their rate.
  options.smooth = settings.quality != FrameQuality::interactive;
  // Files with a normals graph are lit from it unless the frame asks for gradients.
  const bool gradients = settings.label_lighting == LabelLightingChoice::gradient ||
                         settings.label_lighting == LabelLightingChoice::gradient_occlusion;
  options.lighting = gradients || !normals_ ? LabelLighting::gradient : LabelLighting::normals;
  options.occlusion = settings.label_lighting == LabelLightingChoice::gradient_occlusion;
  if (settings.label_lighting == LabelLightingChoice::normals && !normals_)
    throw ParameterError("FrameSettings::label_lighting",
                         labels_.name() + ": has no normals graph (encode it with strata labels encode --normals)");
  options.background = {background[0], background[1], background[2], background[3]};
  LabelRenderStats st;
  Image image = render_labels(scene_, camera, options, &st, normals_.get());
  stats = stats_json(st);
  stats["render"]["smooth"] = options.smooth;
  stats["render"]["lighting"] = options.lighting == LabelLighting::normals ? "normals"
                                : options.occlusion                          ? "gradient-ao"
                                                                             : "gradient";
  return image;
}

Slice<float> LabelSource::value_slice(const SliceSpec&) {
  throw Error(path().string() + ": a label volume has no sample values; ask for label slices");
}

double LabelSource::value_at(const Extent&, int) {
  throw Error(path().string() + ": a label volume has no sample values; ask for the label");
}

std::vector<std::uint32_t> LabelSource::slice_nodes(const SliceSpec& spec, std::pair<int, int>& size) const {
  const Box box = slice_box(labels_.level_dims(spec.level), spec.axis, spec.index >> spec.level);
  size = slice_size(box, spec.axis);
  std::vector<std::uint32_t> ids(std::size_t(box.voxel_count()));
  labels_.decode_box(spec.level, box, ids);
  return ids;
}

Slice<std::int64_t> LabelSource::label_slice(const SliceSpec& spec) {
  check_slice(spec);
  Slice<std::int64_t> out;
  std::pair<int, int> size;
  const std::vector<std::uint32_t> ids = slice_nodes(spec, size);
  std::tie(out.width, out.height) = size;
  // Level-0 ids are the sources themselves; coarser nodes map to their dominant source.
  if (spec.level > 0 && dominant_.empty()) dominant_ = labels_.dominant_sources();
  const mixture::LabelMap& map = labels_.label_map();
  out.values.reserve(ids.size());
  for (std::uint32_t id : ids) out.values.push_back(map.value(spec.level > 0 ? dominant_[id] : id));
  return out;
}

Slice<float> LabelSource::label_fraction_slice(const SliceSpec& spec, std::int64_t label) {
  check_slice(spec);
  if (fraction_label_ != label) {
    fractions_ = labels_.label_fractions(label);
    fraction_label_ = label;
  }
  Slice<float> out;
  std::pair<int, int> size;
  const std::vector<std::uint32_t> ids = slice_nodes(spec, size);
  std::tie(out.width, out.height) = size;
  out.values.reserve(ids.size());
  for (std::uint32_t id : ids) out.values.push_back(fractions_[id]);
  return out;
}

Image LabelSource::palette_slice(const SliceSpec& spec) {
  check_slice(spec);
  if (slice_palette_.empty()) {
    // Every visible label opaque: a slice shows which labels cover a voxel, not how much of
    // the 3D view's opacity they carry.
    std::vector<float> sources = colors_.premultiplied_sources(labels_.label_map());
    for (std::size_t i = 0; i + 3 < sources.size(); i += 4) {
      const float a = sources[i + 3];
      if (a <= 0) continue;
      for (std::size_t c = 0; c < 3; ++c) sources[i + c] /= a;
      sources[i + 3] = 1;
    }
    slice_palette_ = mixture::propagate_palette(labels_.graph(), labels_.schedule(), sources, 4);
  }
  std::pair<int, int> size;
  const std::vector<std::uint32_t> ids = slice_nodes(spec, size);
  // Straight alpha: the colour of the visible labels a voxel holds, and how much of it they
  // cover, so an overlay shows the scalar slice through background and hidden labels (and a
  // label coloured black stays visible).
  Image image(size.first, size.second);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const float* c = slice_palette_.data() + std::size_t(ids[i]) * 4;
    const float a = c[3];
    image.pixels()[i] = a > 0 ? Rgba8{unit_byte(c[0] / a), unit_byte(c[1] / a), unit_byte(c[2] / a), unit_byte(a)}
                              : Rgba8{0, 0, 0, 0};
  }
  return image;
}

std::int64_t LabelSource::label_at(const Extent& voxel) const {
  check_voxel(voxel);
  return labels_.label_map().value(labels_.node_at(0, voxel.x, voxel.y, voxel.z));
}

double LabelSource::set_label_colors(LabelColorMap colors) {
  const auto t0 = SteadyClock::now();
  colors_ = colors;
  scene_.set_color_map(std::move(colors));
  slice_palette_.clear();
  // Propagate now rather than at the next frame, so the caller sees what it cost.
  scene_.prepare(scene_.level_count() - 1, false);
  return ms_since(t0);
}

}  // namespace strata::render
