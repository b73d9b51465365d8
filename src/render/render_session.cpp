// RenderSession: the checks and the frame sizing every kind of file shares, over the file's
// RenderSource (render_source.hpp), which answers everything that depends on the kind.
#include "strata/render/render_session.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <cmath>

#include <fmt/format.h>

#include "render/render_source.hpp"
#include "strata/core/error.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/render/display_defaults.hpp"
#include "strata/render/sampling_limits.hpp"
#include "strata/store/geometry_json.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::render {

std::string_view dataset_kind_name(DatasetKind kind) {
  switch (kind) {
    case DatasetKind::scalar: return "scalar";
    case DatasetKind::labels: return "labels";
    case DatasetKind::plain: break;
  }
  return "plain";
}

namespace {

nlohmann::json json_of(const Extent& e) { return {e.x, e.y, e.z}; }
nlohmann::json json_of(const Spacing& s) { return {s.x, s.y, s.z}; }

// The transfer-function editor's histogram.
constexpr int kViewerHistogramBins = 64;

// How the viewer first shows a scalar dataset (docs/viewer.md): {"tf", "window"}; {} for labels.
nlohmann::json display_defaults(const RenderSource& source, const std::string& preset, double lo, double hi,
                                const std::vector<std::uint64_t>& histogram) {
  if (source.kind() == DatasetKind::labels) return nlohmann::json::object();
  const auto [a, b] = whole_window(percentile_window(histogram, lo, hi), !dtype_is_float(source.dtype()));
  return {{"tf", preset}, {"window", {a, b}}};
}

}  // namespace

void validate(const FrameSettings& s) {
  validate(s.camera);
  check_step(s.step, "FrameSettings::step");
  if (!(s.lod > 0 && s.lod <= 64))
    throw ParameterError("FrameSettings::lod", fmt::format("must lie in (0, 64] pixels per voxel, got {}", s.lod));
  if (!(std::abs(s.lod_bias) <= 64))
    throw ParameterError("FrameSettings::lod_bias", fmt::format("must lie in [-64, 64] levels, got {}", s.lod_bias));
  if (s.rank < 0) throw ParameterError("FrameSettings::rank", fmt::format("must be >= 0 (0 = the stored rank), got {}", s.rank));
  if (!(s.feature_scale >= 0 && s.feature_scale <= 1))
    throw ParameterError("FrameSettings::feature_scale",
                         fmt::format("must be a normalized RMSE in [0, 1] (0 = off), got {}", s.feature_scale));
}

void validate(const SessionOptions& o) {
  if (o.cache_bytes == 0) throw ParameterError("SessionOptions::cache_bytes", "must be positive");
  if (o.model_cache_bytes == 0) throw ParameterError("SessionOptions::model_cache_bytes", "must be positive");
  if (o.max_bricks < 1)
    throw ParameterError("SessionOptions::max_bricks", fmt::format("must be at least 1, got {}", o.max_bricks));
  if (o.loader_threads < 0)
    throw ParameterError("SessionOptions::loader_threads", fmt::format("must be >= 0, got {}", o.loader_threads));
  if (!(o.target_fps >= 0 && o.target_fps <= 1e6))
    throw ParameterError("SessionOptions::target_fps", fmt::format("must lie in [0, 1e6] frames/s, got {}", o.target_fps));
  if (!(o.min_interactive_scale >= 1 && o.min_interactive_scale <= 64))
    throw ParameterError("SessionOptions::min_interactive_scale",
                         fmt::format("must lie in [1, 64], got {}", o.min_interactive_scale));
  for (float c : o.background)
    if (!(c >= 0 && c <= 1))
      throw ParameterError("SessionOptions::background", fmt::format("components must lie in [0, 1], got {}", c));
}

RenderSession::RenderSession(const std::filesystem::path& input, const SessionOptions& options)
    : path_(input), options_(options) {
  validate(options);
  // The one place that tells kinds apart: the opener that accepts the file makes its source.
  source_ = open_render_source(input, options);
  frame_radius_ = source_->frame_radius();
}

RenderSession::~RenderSession() = default;

DatasetKind RenderSession::kind() const { return source_->kind(); }

Extent RenderSession::dims() const { return level_dims(0); }

Spacing RenderSession::spacing() const { return source_->spacing(); }

int RenderSession::level_count() const { return source_->level_count(); }

void RenderSession::check_level(int level) const {
  if (level < 0 || level >= level_count())
    throw ParameterError("level", path_.string() + ": level " + std::to_string(level) + " is not in 0.." +
                                      std::to_string(level_count() - 1));
}

Extent RenderSession::level_dims(int level) const {
  check_level(level);
  return source_->level_dims(level);
}

int RenderSession::stored_rank() const { return source_->stored_rank(); }

std::pair<double, double> RenderSession::value_range() const { return source_->value_range(); }

std::string RenderSession::default_preset() const {
  const auto [lo, hi] = value_range();
  const bool anatomical = source_->geometry().space != WorldSpace::unspecified;
  return render::default_preset(path_.filename().string(), lo, hi, anatomical);
}

bool RenderSession::has_label(std::int64_t label) const { return source_->has_label(label); }

bool RenderSession::has_normals() const { return source_->has_normals(); }

bool RenderSession::has_feature_scale() const { return !source_->feature_scale_ladder().empty(); }

nlohmann::json RenderSession::describe() const {
  const auto [lo, hi] = value_range();
  const std::vector<std::uint64_t> fine = source_->histogram();
  std::string name = path_.filename().string();
  if (options_.volume) name += " (volume " + std::to_string(*options_.volume) + ")";
  return {{"name", name},
          {"kind", dataset_kind_name(kind())},
          {"dims", json_of(dims())},
          {"spacing", json_of(spacing())},
          {"geometry", store::geometry_to_json(source_->geometry())},  // as `.strata` metadata writes it
          {"dtype", dtype_name(source_->dtype())},
          {"levels", level_count()},
          {"rank", stored_rank()},
          {"frame_radius", frame_radius_},
          {"feature_scale_ladder", source_->feature_scale_ladder()},
          {"value_range", {lo, hi}},
          {"histogram", coarser_histogram(fine, kViewerHistogramBins)},
          {"defaults", display_defaults(*source_, default_preset(), lo, hi, fine)},
          {"label_count", source_->label_count()},
          {"label_names", mixture::label_names_json(source_->label_names())},
          {"normals", has_normals()}};
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
  const double budget_ms = 0.9 * 1000.0 / options_.target_fps;
  const double wanted = std::clamp(used_scale * std::sqrt(frame_ms / budget_ms), 1.0, 8.0);
  image_scale_ = calibrated_ ? 0.5 * (image_scale_ + wanted) : wanted;
  calibrated_ = true;
}

Image RenderSession::frame(const FrameSettings& settings, nlohmann::json& stats) {
  validate(settings);
  ta::reconstruction_rank(settings.rank, stored_rank(), path_.string());  // at most the file's rank
  const CameraSpec& spec = settings.camera;
  const bool adaptive = settings.quality == FrameQuality::interactive;
  const double scale = adaptive ? std::max(options_.min_interactive_scale, options_.target_fps > 0 ? image_scale_ : 1.0)
                                : 1.0;
  CameraSpec cast = spec;
  if (cast.frame_radius == 0) cast.frame_radius = frame_radius_;
  cast.width = std::max(1, int(std::lround(spec.width / scale)));
  cast.height = std::max(1, int(std::lround(spec.height / scale)));
  const Camera camera(cast, dims(), spacing());
  const double c0 = cpu_seconds();
  const auto t0 = SteadyClock::now();
  Image image = source_->frame(camera, settings, options_.background, stats);
  if (image.width() != spec.width || image.height() != spec.height)
    image = resize_bilinear(image, spec.width, spec.height);
  const double ms = ms_since(t0);
  stats["frame_ms"] = ms;
  stats["cpu_s"] = cpu_seconds() - c0;
  stats["image_scale"] = scale;
  stats["distance"] = camera.distance();  // resolved: the default framing, so other renderers can match it
  if (options_.target_fps > 0) adapt_image_scale(scale, adaptive ? ms : ray_cast_ms(stats, ms));
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

Slice<float> RenderSession::value_slice(const SliceSpec& spec) { return source_->value_slice(spec); }

Slice<std::int64_t> RenderSession::label_slice(const SliceSpec& spec) { return source_->label_slice(spec); }

Slice<float> RenderSession::label_fraction_slice(const SliceSpec& spec, std::int64_t label) {
  return source_->label_fraction_slice(spec, label);
}

Image RenderSession::palette_slice(const SliceSpec& spec) { return source_->palette_slice(spec); }

double RenderSession::value_at(const Extent& voxel, int rank) { return source_->value_at(voxel, rank); }

std::optional<Pick> RenderSession::pick(const CameraSpec& spec, double px, double py, const TransferFunction& tf,
                                        int rank) {
  ta::reconstruction_rank(rank, stored_rank(), path_.string());
  CameraSpec cast = spec;
  if (cast.frame_radius == 0) cast.frame_radius = frame_radius_;
  const Ray ray = Camera(cast, dims(), spacing()).ray(px, py);
  Pick pick;
  std::optional<VoxelHit> hit;
  if (kind() == DatasetKind::labels) {
    hit = walk_voxels(ray, dims(), spacing(), [&](const Extent& voxel, double) {
      const std::int64_t label = source_->label_at(voxel);
      if (!source_->label_visible(label)) return false;
      pick.label = label;
      return true;
    });
  } else {
    // Opacities are per level-0 voxel of the smallest spacing, as the ray caster's.
    const auto [lo, hi] = value_range();
    const ValueMapping mapping = tf.mapping(lo, hi);
    const Spacing s = spacing();
    const double unit = std::min({s.x, s.y, s.z});
    double transmittance = 1;
    hit = walk_voxels(ray, dims(), s, [&](const Extent& voxel, double length) {
      const double value = source_->value_at(voxel, rank);
      const float alpha = std::isfinite(value) ? tf.evaluate(mapping.normalise(value)).a : 0.0f;
      transmittance *= 1.0 - double(correct_opacity(alpha, length / unit));
      if (1.0 - transmittance < kPickOpacity) return false;
      pick.value = value;
      return true;
    });
  }
  if (!hit) return std::nullopt;
  pick.hit = *hit;
  return pick;
}

std::int64_t RenderSession::label_at(const Extent& voxel) const { return source_->label_at(voxel); }

double RenderSession::set_label_colors(LabelColorMap colors) { return source_->set_label_colors(std::move(colors)); }

const mixture::EncodedLabels& RenderSession::labels() const { return source_->labels(); }

nlohmann::json frame_summary(const nlohmann::json& frames) {
  nlohmann::json all = summarise(frames, 0);
  // An orbit's first frame loads the whole cut; the rest show the interactive rate.
  if (frames.size() > 1) all["after_first"] = summarise(frames, 1);
  return all;
}

}  // namespace strata::render
