// RenderSession: opening a file, describing it and rendering frames (slices, values and label
// colours are in session_slices.cpp).
#include "strata/render/render_session.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <cmath>

#include <fmt/format.h>

#include "render/frame_index.hpp"

#include "render/render_session_parts.hpp"
#include "strata/core/error.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/store/volume_set.hpp"
#include "strata/lod/histogram_bins.hpp"
#include "strata/render/sampling_limits.hpp"
#include "strata/store/brick_histogram.hpp"

namespace strata::render {

std::string_view dataset_kind_name(DatasetKind kind) {
  switch (kind) {
    case DatasetKind::scalar: return "scalar";
    case DatasetKind::labels: return "labels";
    case DatasetKind::plain: break;
  }
  return "plain";
}

RenderOptions render_options(const FrameSettings& s, const std::array<float, 4>& background) {
  RenderOptions o;
  o.step = s.step;
  o.shading = s.shading;
  o.background = background;
  return o;
}

const TransferFunction& frame_tf(const FrameSettings& settings) {
  static const TransferFunction ct = TransferFunction::preset("ct");
  return settings.tf ? *settings.tf : ct;
}

RayCaster& CasterSlot::get(const TransferFunction& tf, const RenderOptions& options) {
  std::string key = fmt::format("{}|{}|{}", tf.to_json().dump(), options.step, options.shading);
  if (!caster_ || key != key_) {
    caster_ = std::make_unique<RayCaster>(tf, options);
    key_ = std::move(key);
  }
  return *caster_;
}

namespace {

lod::ProviderOptions provider_options(const SessionOptions& s) {
  lod::ProviderOptions o;
  o.cache_bytes = s.cache_bytes;
  o.model_cache_bytes = s.model_cache_bytes;
  o.loader_threads = s.loader_threads;
  return o;
}

nlohmann::json json_of(const Extent& e) { return {e.x, e.y, e.z}; }
nlohmann::json json_of(const Spacing& s) { return {s.x, s.y, s.z}; }

}  // namespace

RenderSession::Scalar::Scalar(std::unique_ptr<store::ContainerReader> input, const SessionOptions& s)
    : volume(std::move(input)), provider(volume, provider_options(s)) {
  const auto brick = std::uint64_t(volume.geometry().layout().brick);
  if (s.cache_bytes < brick * brick * brick * sizeof(float))
    throw ParameterError("SessionOptions::cache_bytes",
                         fmt::format("{}: must hold at least one reconstructed brick ({} bytes), got {}",
                                     volume.container().name(), brick * brick * brick * sizeof(float),
                                     s.cache_bytes));
  selection.max_bricks = s.max_bricks;
  selection.memory_budget = s.cache_bytes;
}

Image RenderSession::Scalar::frame(const Camera& camera, const FrameSettings& settings, const RenderOptions& options,
                                   nlohmann::json& stats) {
  const TransferFunction& tf = frame_tf(settings);
  RayCaster& caster = casters.get(tf, options);
  const auto t0 = SteadyClock::now();
  lod::SelectionOptions cut_options = selection;
  cut_options.lod = settings.lod;
  cut_options.feature_scale = settings.feature_scale;
  const std::uint64_t visible_bins = tf.visible_bins(volume.value_min(), volume.value_max());
  const lod::Selection cut = lod::select_cut(volume, camera.view(), visible_bins, cut_options);
  const double select_ms = ms_since(t0);
  const int rank = settings.rank > 0 ? settings.rank : volume.rank();
  const lod::FrameBricks bricks = provider.acquire(cut, rank, settings.quality == FrameQuality::exact);
  FrameInput input;
  input.bricks = &bricks;
  input.geometry = &volume.geometry();
  input.spacing = volume.source_info().spacing;
  input.value_min = volume.value_min();
  input.value_max = volume.value_max();
  input.index = &volume.container();
  RenderStats rs;
  Image image = caster.render(camera, input, &rs);
  stats = stats_json(rs, &bricks.stats);
  stats["selection"] = {{"bricks", cut.bricks.size()},  {"per_level", cut.per_level},
                        {"bytes", cut.bytes},           {"budget_hit", cut.budget_hit()},
                        {"culled_frustum", cut.culled_frustum}, {"culled_empty", cut.culled_empty},
                        {"select_ms", select_ms}};
  if (settings.feature_scale > 0) {
    // The ranks drawn: the chosen ones, capped by the frame's rank.
    std::map<int, std::int64_t> drawn;
    for (const auto& [k, count] : cut.per_rank) drawn[std::min(k, provider.clamp_rank(rank))] += count;
    nlohmann::json per_rank = nlohmann::json::object();
    for (const auto& [k, count] : drawn) per_rank[std::to_string(k)] = count;
    stats["selection"]["feature_scale"] = settings.feature_scale;
    stats["selection"]["per_rank"] = per_rank;
  }
  stats["rank"] = provider.clamp_rank(rank);
  return image;
}

FrameSphere::FrameSphere(const Extent& dims, const Spacing& spacing)
    : centre{0.5 * double(dims.x) * spacing.x, 0.5 * double(dims.y) * spacing.y, 0.5 * double(dims.z) * spacing.z},
      bounding(length(centre)) {}

void FrameSphere::add_box(const Vec3& lo, const Vec3& hi) {
  const Vec3 far{std::max(std::abs(lo.x - centre.x), std::abs(hi.x - centre.x)),
                 std::max(std::abs(lo.y - centre.y), std::abs(hi.y - centre.y)),
                 std::max(std::abs(lo.z - centre.z), std::abs(hi.z - centre.z))};
  radius = std::max(radius, length(far));
}

void FrameSphere::add_cell(const Extent& dims0, const Spacing& s, int level, std::int64_t x, std::int64_t y,
                           std::int64_t z) {
  const double cell = std::ldexp(1.0, level);
  add_box({double(x) * cell * s.x, double(y) * cell * s.y, double(z) * cell * s.z},
          {std::min(double(x + 1) * cell, double(dims0.x)) * s.x, std::min(double(y + 1) * cell, double(dims0.y)) * s.y,
           std::min(double(z + 1) * cell, double(dims0.z)) * s.z});
}

double FrameSphere::rounded() const {
  if (radius <= 0) return 0;
  const double step = bounding / kSteps;
  return std::min(bounding, std::ceil(radius / step) * step);
}

int frame_level(Extent dims) {
  int level = 0;
  while (std::max({dims.x, dims.y, dims.z}) > FrameSphere::kWidest) {
    dims = ta::half_extent(dims);
    ++level;
  }
  return level;
}

namespace {

// The cells of `coarse` (level `level` of a volume of `dims0`) that the default transfer
// function shows, over the value range [lo, hi].
double visible_cells_radius(const Volume& coarse, int level, const Extent& dims0, const Spacing& s, double lo, double hi) {
  FrameSphere sphere(dims0, s);
  const std::uint64_t bins = frame_tf(FrameSettings{}).visible_bins(lo, hi);
  const store::HistogramBinning binning(lo, hi);
  const auto v = coarse.view<float>();
  const Extent d = coarse.dims();
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const float f = v(x, y, z);
        if (std::isfinite(f) && ((bins >> binning.bin(f)) & 1u)) sphere.add_cell(dims0, s, level, x, y, z);
      }
  return sphere.rounded();
}

}  // namespace

// The cells of the coarsest level at most 64 wide that the default transfer function shows,
// decoded at the stored rank: the same rule as a plain volume's, box-filtered to that level.
double RenderSession::Scalar::frame_radius() const {
  const Extent d0 = volume.source_info().dims;
  const int level = std::min(frame_level(d0), volume.geometry().level_count() - 1);
  const Volume coarse = volume.decode_box(level, Box::whole(volume.geometry().level(level).dims), volume.rank());
  return visible_cells_radius(coarse, level, d0, volume.source_info().spacing, volume.value_min(), volume.value_max());
}

// One count per level-0 brick and histogram bin it touches (the index's occupancy masks).
std::vector<std::uint64_t> RenderSession::Scalar::histogram() const {
  std::vector<std::uint64_t> counts(store::kHistogramBins, 0);
  for (const store::BrickEntry& e : volume.container().bricks()) {
    if (e.key.level != 0) continue;
    if (e.kind == store::PayloadKind::constant) {
      if (std::isfinite(e.min)) ++counts[std::size_t(lod::histogram_bin(e.min, volume.value_min(), volume.value_max()))];
      continue;  // all NaN or infinite: empty space, no value to count
    }
    for (int bin = 0; bin < store::kHistogramBins; ++bin) counts[std::size_t(bin)] += (e.histogram >> bin) & 1u;
  }
  return counts;
}

// Voxels of the coarsest level at most 64 wide whose footprint holds any label but 0.
double RenderSession::Labels::frame_radius() const {
  const Spacing s = labels.spacing();
  const Extent d0 = labels.level_dims(0);
  FrameSphere sphere(d0, s);
  const std::optional<std::uint32_t> background = labels.label_map().id_of(0);
  if (!background) {
    sphere.add_box({0, 0, 0}, {double(d0.x) * s.x, double(d0.y) * s.y, double(d0.z) * s.z});
    return sphere.rounded();
  }
  const int level = std::min(frame_level(d0), labels.level_count() - 1);
  const Extent d = labels.level_dims(level);
  std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()));
  labels.decode_box(level, Box::whole(d), ids);
  const std::vector<float> background_share = labels.label_fractions(0);
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x)
        if (background_share[ids[std::size_t((z * d.y + y) * d.x + x)]] < 1.0f) sphere.add_cell(d0, s, level, x, y, z);
  return sphere.rounded();
}

RenderSession::Labels::Labels(std::unique_ptr<store::ContainerReader> input)
    : labels(std::move(input)), scene(labels, LabelColorMap{}) {
  if (labels.has_normals()) normals = std::make_unique<LabelShading>(labels.open_normals());
}

Image RenderSession::Labels::frame(const Camera& camera, const FrameSettings& settings,
                                   const std::array<float, 4>& background, nlohmann::json& stats) {
  LabelRenderOptions options;
  options.lod_bias = settings.lod_bias;
  options.step = settings.step;
  options.shading = settings.shading;
  // Files with a normals graph are lit from it unless the frame asks for gradients.
  const bool gradients = settings.label_lighting == LabelLightingChoice::gradient ||
                         settings.label_lighting == LabelLightingChoice::gradient_occlusion;
  options.lighting = gradients || !normals ? LabelLighting::gradient : LabelLighting::normals;
  options.occlusion = settings.label_lighting == LabelLightingChoice::gradient_occlusion;
  if (settings.label_lighting == LabelLightingChoice::normals && !normals)
    throw ParameterError("FrameSettings::label_lighting",
                         labels.name() + ": has no normals graph (encode it with strata labels encode --normals)");
  options.background = {background[0], background[1], background[2], background[3]};
  LabelRenderStats st;
  Image image = render_labels(scene, camera, options, &st, normals.get());
  stats = stats_json(st);
  stats["render"]["lighting"] = options.lighting == LabelLighting::normals ? "normals"
                                : options.occlusion                          ? "gradient-ao"
                                                                             : "gradient";
  return image;
}

namespace {

Volume load_as_float(const std::filesystem::path& input, std::optional<std::int64_t> volume, DType& source_dtype) {
  io::ReadOptions read;
  read.volume = volume;
  Volume source = io::read_volume(input, read);
  source_dtype = source.dtype();
  return source.converted(DType::f32);
}

// The range of the finite samples (NaN and infinite ones are empty space); {0, 0} without any.
std::pair<double, double> sample_range(const Volume& v) {
  const auto s = v.samples<float>();
  const auto [lo, hi] = detail::finite_range(s.data(), s.size());
  if (!(lo <= hi)) return {0, 0};
  return {lo, hi};
}

}  // namespace

RenderSession::Plain::Plain(const std::filesystem::path& input, std::optional<std::int64_t> volume_index)
    : volume(load_as_float(input, volume_index, source_dtype)), range(sample_range(volume)), prepared(volume) {}

Image RenderSession::Plain::frame(const Camera& camera, const FrameSettings& settings, const RenderOptions& options,
                                  nlohmann::json& stats) {
  RayCaster& caster = casters.get(frame_tf(settings), options);
  RenderStats rs;
  Image image = caster.render(camera, prepared, &rs);
  stats = stats_json(rs);
  return image;
}

// The volume box-filtered to the coarsest level at most 64 wide (as a TA file's pyramid),
// then the cells the default transfer function shows.
double RenderSession::Plain::frame_radius() const {
  const int level = frame_level(volume.dims());
  if (level == 0) return visible_cells_radius(volume, 0, volume.dims(), volume.spacing(), range.first, range.second);
  Volume coarse = ta::half_resolution(volume);  // halved straight from the volume: no full-size copy
  for (int l = 1; l < level; ++l) coarse = ta::half_resolution(coarse);
  return visible_cells_radius(coarse, level, volume.dims(), volume.spacing(), range.first, range.second);
}

// Exact voxel counts in 64 bins over the value range, binned as the compressor bins bricks;
// NaN and infinite voxels (empty space) are not counted.
std::vector<std::uint64_t> RenderSession::Plain::histogram() const {
  std::vector<std::uint64_t> counts(store::kHistogramBins, 0);
  const store::HistogramBinning binning(range.first, range.second);
  for (float v : volume.samples<float>())
    if (std::isfinite(v)) ++counts[std::size_t(binning.bin(v))];
  return counts;
}

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
  if (!store::is_strata_file(input)) {
    plain_ = std::make_unique<Plain>(input, options.volume);
  } else {
    // One reader, opened once: its codec picks the session kind, which takes it over.
    auto reader = store::open_volume(input, options.volume);
    if (reader->metadata().value("codec", std::string()) == mixture::kMixtureCodecName)
      labels_ = std::make_unique<Labels>(std::move(reader));
    else
      scalar_ = std::make_unique<Scalar>(std::move(reader), options);
  }
  frame_radius_ = plain_ ? plain_->frame_radius() : labels_ ? labels_->frame_radius() : scalar_->frame_radius();
}

RenderSession::~RenderSession() = default;

DatasetKind RenderSession::kind() const {
  return plain_ ? DatasetKind::plain : labels_ ? DatasetKind::labels : DatasetKind::scalar;
}

Extent RenderSession::dims() const { return level_dims(0); }

Spacing RenderSession::spacing() const {
  if (plain_) return plain_->volume.spacing();
  return labels_ ? labels_->labels.spacing() : scalar_->volume.source_info().spacing;
}

int RenderSession::level_count() const {
  if (plain_) return 1;
  return labels_ ? labels_->labels.level_count() : scalar_->volume.geometry().level_count();
}

void RenderSession::check_level(int level) const {
  if (level < 0 || level >= level_count())
    throw ParameterError("level", path_.string() + ": level " + std::to_string(level) + " is not in 0.." +
                                      std::to_string(level_count() - 1));
}

Extent RenderSession::level_dims(int level) const {
  check_level(level);
  if (plain_) return plain_->volume.dims();
  return labels_ ? labels_->labels.level_dims(level) : scalar_->volume.geometry().level(level).dims;
}

int RenderSession::stored_rank() const { return scalar_ ? scalar_->volume.rank() : 0; }

std::pair<double, double> RenderSession::value_range() const {
  if (plain_) return plain_->range;
  if (scalar_) return {scalar_->volume.value_min(), scalar_->volume.value_max()};
  const auto values = labels_->labels.label_map().values();
  return values.empty() ? std::pair{0.0, 0.0} : std::pair{double(values.front()), double(values.back())};
}

bool RenderSession::has_label(std::int64_t label) const {
  return labels_ && labels_->labels.label_map().id_of(label).has_value();
}

bool RenderSession::has_normals() const { return labels_ && labels_->normals != nullptr; }

bool RenderSession::has_feature_scale() const { return scalar_ && !scalar_->volume.feature_scale_ladder().empty(); }

nlohmann::json RenderSession::describe() const {
  const auto [lo, hi] = value_range();
  const DType dtype = plain_    ? plain_->source_dtype
                      : labels_ ? labels_->labels.label_map().dtype()
                                : scalar_->volume.source_info().dtype;
  const std::vector<std::uint64_t> histogram = plain_    ? plain_->histogram()
                                               : scalar_ ? scalar_->histogram()
                                                         : std::vector<std::uint64_t>{};
  std::string name = path_.filename().string();
  if (options_.volume) name += " (volume " + std::to_string(*options_.volume) + ")";
  return {{"name", name},
          {"kind", dataset_kind_name(kind())},
          {"dims", json_of(dims())},
          {"spacing", json_of(spacing())},
          {"dtype", dtype_name(dtype)},
          {"levels", level_count()},
          {"rank", stored_rank()},
          {"frame_radius", frame_radius_},
          {"feature_scale_ladder", scalar_ ? nlohmann::json(scalar_->volume.feature_scale_ladder()) : nlohmann::json::array()},
          {"value_range", {lo, hi}},
          {"histogram", histogram},
          {"label_count", labels_ ? labels_->labels.label_map().size() : 0u},
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
  const CameraSpec& spec = settings.camera;
  const bool adaptive = settings.quality == FrameQuality::interactive;
  const double scale = adaptive ? std::max(options_.min_interactive_scale, options_.target_fps > 0 ? image_scale_ : 1.0)
                                : 1.0;
  CameraSpec cast = spec;
  if (cast.frame_radius == 0) cast.frame_radius = frame_radius_;
  cast.width = std::max(1, int(std::lround(spec.width / scale)));
  cast.height = std::max(1, int(std::lround(spec.height / scale)));
  const Camera camera(cast, dims(), spacing());
  const RenderOptions options = render_options(settings, options_.background);
  const double c0 = cpu_seconds();
  const auto t0 = SteadyClock::now();
  Image image = plain_    ? plain_->frame(camera, settings, options, stats)
                : labels_ ? labels_->frame(camera, settings, options_.background, stats)
                          : scalar_->frame(camera, settings, options, stats);
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

nlohmann::json frame_summary(const nlohmann::json& frames) {
  nlohmann::json all = summarise(frames, 0);
  // An orbit's first frame loads the whole cut; the rest show the interactive rate.
  if (frames.size() > 1) all["after_first"] = summarise(frames, 1);
  return all;
}

}  // namespace strata::render
