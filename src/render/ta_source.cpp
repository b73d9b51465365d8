// TaSource: a TA file opened for viewing. Frames go through the LOD cut, the brick provider
// (cache + loader) and the ray caster; slices and voxel values through the same provider.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include <fmt/format.h>

#include "render/render_source_kinds.hpp"
#include "strata/render/display_defaults.hpp"
#include "strata/core/error.hpp"
#include "strata/core/stopwatch.hpp"

namespace strata::render {

namespace {

lod::ProviderOptions provider_options(const SessionOptions& s) {
  lod::ProviderOptions o;
  o.cache_bytes = s.cache_bytes;
  o.model_cache_bytes = s.model_cache_bytes;
  o.loader_threads = s.loader_threads;
  return o;
}

}  // namespace

TaSource::TaSource(std::filesystem::path path, std::unique_ptr<store::ContainerReader> input, const SessionOptions& s)
    : RenderSource(std::move(path)), volume_(std::move(input)), provider_(volume_, provider_options(s)) {
  const auto brick = std::uint64_t(volume_.geometry().layout().brick);
  if (s.cache_bytes < brick * brick * brick * sizeof(float))
    throw ParameterError("SessionOptions::cache_bytes",
                         fmt::format("{}: must hold at least one reconstructed brick ({} bytes), got {}",
                                     volume_.container().name(), brick * brick * brick * sizeof(float),
                                     s.cache_bytes));
  selection_.max_bricks = s.max_bricks;
  selection_.memory_budget = s.cache_bytes;
}

Image TaSource::frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
                      nlohmann::json& stats) {
  const RenderOptions options = render_options(settings, background);
  const TransferFunction& tf = frame_tf(settings);
  RayCaster& caster = casters_.get(tf, options);
  const auto t0 = SteadyClock::now();
  lod::SelectionOptions cut_options = selection_;
  cut_options.lod = settings.lod;
  cut_options.feature_scale = settings.feature_scale;
  const std::uint64_t visible_bins = tf.visible_bins(volume_.value_min(), volume_.value_max());
  const lod::Selection cut = lod::select_cut(volume_, camera.view(), visible_bins, cut_options);
  const double select_ms = ms_since(t0);
  const int rank = settings.rank > 0 ? settings.rank : volume_.rank();
  const lod::FrameBricks bricks = provider_.acquire(cut, rank, settings.quality == FrameQuality::exact);
  FrameInput input;
  input.bricks = &bricks;
  input.geometry = &volume_.geometry();
  input.spacing = volume_.source_info().spacing;
  input.value_min = volume_.value_min();
  input.value_max = volume_.value_max();
  input.index = &volume_.container();
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
    for (const auto& [k, count] : cut.per_rank) drawn[std::min(k, provider_.clamp_rank(rank))] += count;
    nlohmann::json per_rank = nlohmann::json::object();
    for (const auto& [k, count] : drawn) per_rank[std::to_string(k)] = count;
    stats["selection"]["feature_scale"] = settings.feature_scale;
    stats["selection"]["per_rank"] = per_rank;
  }
  stats["rank"] = provider_.clamp_rank(rank);
  return image;
}

// The cells of the coarsest level at most 64 wide that the default transfer function shows,
// decoded at the stored rank: the same rule as a plain volume's, box-filtered to that level.
double TaSource::frame_radius() const {
  const Extent d0 = volume_.source_info().dims;
  const int level = std::min(frame_level(d0), volume_.geometry().level_count() - 1);
  const Volume coarse = volume_.decode_box(level, Box::whole(volume_.geometry().level(level).dims), volume_.rank());
  return visible_cells_radius(coarse, level, d0, volume_.source_info().spacing, volume_.value_min(), volume_.value_max());
}

// The values of the finest level of at most kHistogramVoxels voxels, decoded at the stored
// rank: a true value histogram (the index's per-brick occupancy bits counted every bin a brick
// touches once, which flattened it: 4.8% in the first bin of a CT whose voxels hold 73.6%),
// at the cost of decoding about 2M voxels once, when a viewer first asks.
std::vector<std::uint64_t> TaSource::histogram() const {
  constexpr std::int64_t kHistogramVoxels = std::int64_t(1) << 21;
  const ta::OctreeGeometry& g = volume_.geometry();
  int level = 0;
  while (level + 1 < g.level_count() && g.level(level).dims.voxel_count() > kHistogramVoxels) ++level;
  const Volume values = volume_.decode_box(level, Box::whole(g.level(level).dims), volume_.rank());
  return value_histogram(values.samples<float>(), volume_.value_min(), volume_.value_max());
}

template <class F>
void TaSource::visit_box(int level, const Box& box, int rank, F&& f) {
  const ta::OctreeGeometry& geometry = volume_.geometry();
  const int b = geometry.layout().brick;
  // A slice one voxel thick needs whole B^3 bricks: they are acquired a batch at a time, so a
  // large slice holds at most a batch beyond what the cache keeps.
  constexpr std::size_t kBatch = 64;
  lod::Selection cut;
  auto visit_batch = [&] {
    const lod::FrameBricks bricks = provider_.acquire(cut, rank > 0 ? rank : volume_.rank(), true);
    for (const lod::ResidentBrick& brick : bricks.bricks) {
      const Box part = geometry.brick_core_box(level, brick.key.x, brick.key.y, brick.key.z).intersect(box);
      const Extent o = geometry.brick_sample_box(level, brick.key.x, brick.key.y, brick.key.z).lo;
      for (std::int64_t z = part.lo.z; z < part.hi.z; ++z)
        for (std::int64_t y = part.lo.y; y < part.hi.y; ++y)
          for (std::int64_t x = part.lo.x; x < part.hi.x; ++x)
            f(x, y, z,
              brick.is_constant() ? brick.constant_value
                                  : (*brick.samples)[std::size_t(((z - o.z) * b + (y - o.y)) * b + (x - o.x))]);
    }
    cut.bricks.clear();
  };
  for_each_brick_in(level, box, [&](const lod::CutBrick& brick) {
    cut.bricks.push_back(brick);
    if (cut.bricks.size() == kBatch) visit_batch();
  });
  if (!cut.bricks.empty()) visit_batch();
}

template <class F>
void TaSource::for_each_brick_in(int level, const Box& box, F&& f) const {
  const int core = volume_.geometry().layout().core();
  for (std::int64_t bz = box.lo.z / core; bz <= (box.hi.z - 1) / core; ++bz)
    for (std::int64_t by = box.lo.y / core; by <= (box.hi.y - 1) / core; ++by)
      for (std::int64_t bx = box.lo.x / core; bx <= (box.hi.x - 1) / core; ++bx) {
        const store::BrickKey key{std::uint8_t(level), std::int32_t(bx), std::int32_t(by), std::int32_t(bz)};
        f(lod::CutBrick{key, &volume_.entry(key), 0.0, 0.0});
      }
}

void TaSource::prefetch_slice_neighbours(const SliceSpec& spec) {
  const Extent& dims = volume_.geometry().level(spec.level).dims;
  const std::int64_t core = volume_.geometry().layout().core();
  const std::int64_t extent = spec.axis == SliceAxis::x ? dims.x : spec.axis == SliceAxis::y ? dims.y : dims.z;
  const std::int64_t index = spec.index >> spec.level;
  lod::Selection cut;
  // A slice one core width away lies in the neighbouring layer (clamped: at the volume's edge
  // it is the slice's own layer, whose bricks are resident and not queued again).
  for (const std::int64_t neighbour : {index + core, index - core})
    for_each_brick_in(spec.level, slice_box(dims, spec.axis, std::clamp<std::int64_t>(neighbour, 0, extent - 1)),
                      [&](const lod::CutBrick& brick) { cut.bricks.push_back(brick); });
  provider_.prefetch(cut, spec.rank > 0 ? spec.rank : volume_.rank());
}

Slice<float> TaSource::value_slice(const SliceSpec& spec) {
  check_slice(spec);
  const Box box = level_slice_box(spec);
  Slice<float> out = empty_slice<float>(box, spec.axis);
  visit_box(spec.level, box, spec.rank, [&](std::int64_t x, std::int64_t y, std::int64_t z, float v) {
    out.values[slice_offset(box, spec.axis, x, y, z)] = v;
  });
  prefetch_slice_neighbours(spec);
  return out;
}

double TaSource::value_at(const Extent& voxel, int rank) {
  check_voxel(voxel);
  double value = 0;
  visit_box(0, {voxel, {voxel.x + 1, voxel.y + 1, voxel.z + 1}}, rank,
            [&](std::int64_t, std::int64_t, std::int64_t, float v) { value = v; });
  return value;
}

}  // namespace strata::render
