#include "render_session.hpp"

#include <algorithm>
#include <cmath>

#include "strata/core/stopwatch.hpp"
#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/lod/brick_provider.hpp"
#include "strata/lod/selection.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/label_color_map.hpp"
#include "strata/render/label_raycaster.hpp"
#include "strata/render/label_scene.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/transfer_function.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::cli {

namespace {

render::RenderOptions render_options(const RenderSettings& s) {
  render::RenderOptions o;
  o.step = s.step;
  o.shading = s.shading;
  o.background = s.background;
  return o;
}

lod::ProviderOptions provider_options(const RenderSettings& s) {
  lod::ProviderOptions o;
  o.cache_bytes = s.cache_bytes;
  return o;
}

}  // namespace

// A TA file: LOD cut -> brick provider -> ray caster.
struct RenderSession::Scalar {
  ta::TaVolume volume;
  lod::BrickProvider provider;
  render::RayCaster caster;
  std::uint64_t visible_bins;
  lod::SelectionOptions selection;
  int rank;

  Scalar(std::unique_ptr<store::ContainerReader> input, const RenderSettings& s)
      : volume(std::move(input)),
        provider(volume, provider_options(s)),
        caster(render::TransferFunction::from_argument(s.tf), render_options(s)),
        visible_bins(caster.transfer_function().visible_bins(volume.value_min(), volume.value_max())),
        rank(s.rank > 0 ? s.rank : volume.rank()) {
    selection.lod = s.lod;
    selection.max_bricks = s.max_bricks;
    selection.memory_budget = s.cache_bytes;
  }

  render::Image frame(const render::Camera& camera, bool exact, nlohmann::json& stats) {
    const auto t0 = SteadyClock::now();
    const lod::Selection cut = lod::select_cut(volume, camera.view(), visible_bins, selection);
    const double select_ms = ms_since(t0);
    const lod::FrameBricks bricks = provider.acquire(cut, rank, exact);
    render::FrameInput input;
    input.bricks = &bricks;
    input.geometry = &volume.geometry();
    input.spacing = volume.source_info().spacing;
    input.value_min = volume.value_min();
    input.value_max = volume.value_max();
    input.index = &volume.container();
    render::RenderStats rs;
    render::Image image = caster.render(camera, input, &rs);
    stats = render::stats_json(rs, &bricks.stats);
    stats["selection"] = {{"bricks", cut.bricks.size()},  {"per_level", cut.per_level},
                          {"bytes", cut.bytes},           {"budget_hit", cut.budget_hit()},
                          {"culled_frustum", cut.culled_frustum}, {"culled_empty", cut.culled_empty},
                          {"select_ms", select_ms}};
    stats["rank"] = provider.clamp_rank(rank);
    return image;
  }
};

// A label file: palette through the Mixture Graph, then the label ray caster. The scene keeps
// decoded node ids, so later frames only march (and recolour when asked).
struct RenderSession::Labels {
  mixture::EncodedLabels labels;
  render::LabelScene scene;
  render::LabelRenderOptions options;

  Labels(std::unique_ptr<store::ContainerReader> input, const RenderSettings& s)
      : labels(std::move(input)), scene(labels, s.colors.empty() ? render::LabelColorMap{} : render::LabelColorMap::load(s.colors)) {
    options.lod_bias = s.lod_bias;
    options.step = s.step;
    options.shading = s.shading;
    options.background = {s.background[0], s.background[1], s.background[2], s.background[3]};
  }

  render::Image frame(const render::Camera& camera, nlohmann::json& stats) {
    render::LabelRenderStats st;
    render::Image image = render::render_labels(scene, camera, options, &st);
    stats = render::stats_json(st);
    return image;
  }
};

// A plain volume file (raw, NRRD, NIfTI, TIFF): loaded whole as floats and ray cast as one
// block, the uncompressed reference a compressed file's rendering can be compared with. Its
// value range and empty-space cells are worked out once, not per frame.
struct RenderSession::Plain {
  Volume volume;
  render::RayCaster caster;
  render::PreparedVolume prepared;

  Plain(const std::filesystem::path& input, const RenderSettings& s)
      : volume(io::read_volume(input).converted(DType::f32)),
        caster(render::TransferFunction::from_argument(s.tf), render_options(s)),
        prepared(volume) {}  // over the volume's own value range

  render::Image frame(const render::Camera& camera, nlohmann::json& stats) {
    render::RenderStats rs;
    render::Image image = caster.render(camera, prepared, &rs);
    stats = render::stats_json(rs);
    return image;
  }
};

RenderSession::RenderSession(const std::filesystem::path& input, const RenderSettings& settings)
    : target_fps_(settings.target_fps) {
  if (!(settings.target_fps >= 0)) throw Error("target frame rate must be >= 0");
  if (!store::is_strata_file(input)) {
    plain_ = std::make_unique<Plain>(input, settings);
    return;
  }
  // One reader, opened once: its codec picks the session kind, which takes it over.
  auto reader = std::make_unique<store::ContainerReader>(input);
  if (reader->metadata().value("codec", std::string()) == mixture::kMixtureCodecName)
    labels_ = std::make_unique<Labels>(std::move(reader), settings);
  else
    scalar_ = std::make_unique<Scalar>(std::move(reader), settings);
}

RenderSession::~RenderSession() = default;

Extent RenderSession::dims() const {
  if (plain_) return plain_->volume.dims();
  return labels_ ? labels_->labels.level_dims(0) : scalar_->volume.source_info().dims;
}
Spacing RenderSession::spacing() const {
  if (plain_) return plain_->volume.spacing();
  return labels_ ? labels_->labels.spacing() : scalar_->volume.source_info().spacing;
}

void RenderSession::set_rank(int rank) {
  if (scalar_) scalar_->rank = rank > 0 ? rank : scalar_->volume.rank();
}

namespace {

// The ray casting share of a frame (a loading frame also waits for decoding).
double ray_cast_ms(const nlohmann::json& stats, double frame_ms) {
  if (stats.contains("render") && stats["render"].contains("raycast_ms")) return stats["render"]["raycast_ms"].get<double>();
  if (stats.contains("render") && stats["render"].contains("march_ms")) return stats["render"]["march_ms"].get<double>();
  return frame_ms;
}

}  // namespace

// Frame time scales with the ray count, i.e. with 1 / scale^2. The first measurement sets the
// scale outright; later ones are damped so one slow frame (a burst of misses) does not swing
// the resolution. Aim 10% under the budget so the mean holds it despite jitter.
void RenderSession::adapt_image_scale(double used_scale, double frame_ms) {
  const double budget_ms = 0.9 * 1000.0 / target_fps_;
  const double wanted = std::clamp(used_scale * std::sqrt(frame_ms / budget_ms), 1.0, 8.0);
  image_scale_ = calibrated_ ? 0.5 * (image_scale_ + wanted) : wanted;
  calibrated_ = true;
}

render::Image RenderSession::frame(const render::CameraSpec& spec, bool exact, nlohmann::json& stats) {
  const bool adaptive = target_fps_ > 0 && !exact;
  render::CameraSpec cast = spec;
  if (adaptive) {
    cast.width = std::max(1, int(std::lround(spec.width / image_scale_)));
    cast.height = std::max(1, int(std::lround(spec.height / image_scale_)));
  }
  const render::Camera camera(cast, dims(), spacing());
  const double c0 = cpu_seconds();
  const auto t0 = SteadyClock::now();
  render::Image image = plain_    ? plain_->frame(camera, stats)
                        : labels_ ? labels_->frame(camera, stats)
                                  : scalar_->frame(camera, exact, stats);
  if (image.width() != spec.width || image.height() != spec.height)
    image = render::resize_bilinear(image, spec.width, spec.height);
  const double ms = ms_since(t0);
  stats["frame_ms"] = ms;
  stats["cpu_s"] = cpu_seconds() - c0;
  stats["image_scale"] = adaptive ? image_scale_ : 1.0;
  if (target_fps_ > 0) adapt_image_scale(adaptive ? image_scale_ : 1.0, adaptive ? ms : ray_cast_ms(stats, ms));
  return image;
}

namespace {

nlohmann::json summarise(const nlohmann::json& frames, std::size_t first) {
  double total = 0, decode = 0, cpu = 0;
  for (std::size_t i = first; i < frames.size(); ++i) {
    const auto& f = frames[i];
    total += f.value("frame_ms", 0.0);
    cpu += f.value("cpu_s", 0.0);
    if (f.contains("load")) decode += f["load"].value("decode_ms", 0.0);
  }
  const std::size_t count = frames.size() > first ? frames.size() - first : 0;
  const double n = double(std::max<std::size_t>(1, count));
  return {{"frames", count},
          {"mean_frame_ms", total / n},
          {"frames_per_s", total > 0 ? 1000.0 * n / total : 0.0},
          {"cpu_s_per_frame", cpu / n},
          {"decode_share", total > 0 ? decode / total : 0.0}};
}

}  // namespace

nlohmann::json frame_summary(const nlohmann::json& frames) {
  nlohmann::json all = summarise(frames, 0);
  // An orbit's first frame loads the whole cut; the rest show the interactive rate.
  if (frames.size() > 1) all["after_first"] = summarise(frames, 1);
  return all;
}

}  // namespace strata::cli
