// The RayCaster API: option checks, construction, and the render entry points for a frame's
// bricks and for a plain volume, which gather a frame's empty-space flags (occupancy.hpp) and
// level tables (level_tables.hpp) and cast through ray_traversal.hpp; and stats_json.
#include "strata/core/stopwatch.hpp"
#include "strata/render/raycaster.hpp"

#include <algorithm>
#include <atomic>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "render/frame_index.hpp"
#include "render/level_tables.hpp"
#include "render/occupancy.hpp"
#include "render/ray_sampling.hpp"
#include "render/ray_traversal.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/render/sampling_limits.hpp"

namespace strata::render {

using detail::attach_flags;
using detail::Block;
using detail::cell_flags;
using detail::CellFlags;
using detail::FrameIndex;
using detail::LevelParams;
using detail::level_params;
using detail::run;
using detail::skip_dilation;
using detail::Transparency;

namespace {

void validate(const RenderOptions& o) {
  check_step(o.step, "RenderOptions::step");
  if (o.table_size < 2 || o.table_size > 4096)
    throw ParameterError("RenderOptions::table_size", "must lie in 2..4096, got " + std::to_string(o.table_size));
  if (o.tile < 1) throw ParameterError("RenderOptions::tile", "must be positive, got " + std::to_string(o.tile));
  if (!(o.termination_alpha > 0 && o.termination_alpha <= 1))
    throw ParameterError("RenderOptions::termination_alpha",
                         fmt::format("must lie in (0, 1], got {}", o.termination_alpha));
  for (float c : o.background)
    if (!(c >= 0 && c <= 1))
      throw ParameterError("RenderOptions::background", fmt::format("components must lie in [0, 1], got {}", c));
}

// Tells PreparedVolume which caster's empty-space cells it holds.
std::atomic<std::uint64_t> next_caster_id{0};

}  // namespace

RayCaster::RayCaster(TransferFunction tf, RenderOptions options)
    : tf_(std::move(tf)),
      options_(options),
      transparency_(std::make_unique<const Transparency>(tf_)),
      id_(next_caster_id.fetch_add(1)) {
  validate(options_);
}
RayCaster::~RayCaster() = default;
RayCaster::RayCaster(RayCaster&&) noexcept = default;
RayCaster& RayCaster::operator=(RayCaster&&) noexcept = default;

Image RayCaster::render(const Camera& camera, const FrameInput& frame, RenderStats* stats) {
  const auto t0 = SteadyClock::now();
  FrameIndex index = detail::build_frame_index(frame, tf_);
  RenderStats local;
  local.bricks_in_frame = index.blocks.size();
  for (const Block& b : index.blocks) local.bricks_culled += b.culled ? 1 : 0;
  const ValueMapping mapping = tf_.mapping(frame.value_min, frame.value_max);
  std::vector<std::shared_ptr<const CellFlags>> flags;  // kept alive for the frame
  if (const int dilation = skip_dilation(options_)) {
    // Macro-cell flags of the visible bricks: memoised per brick, computed in parallel when new.
    if (!cell_flags_) cell_flags_ = std::make_unique<detail::CellFlagCache>();
    detail::CellFlagCache& cache = *cell_flags_;
    cache.sweep();
    const std::array<double, 2> key{double(float(mapping.lo)), double(float(mapping.scale()))};
    if (cache.key != key) {
      cache.clear();
      cache.key = key;
    }
    const auto& bricks = frame.bricks->bricks;
    flags.resize(bricks.size());
    std::vector<std::size_t> missing;
    for (std::size_t i = 0; i < bricks.size(); ++i) {
      if (index.blocks[i].culled || bricks[i].is_constant()) continue;
      flags[i] = cache.find(bricks[i].samples);
      if (!flags[i]) missing.push_back(i);
    }
    const std::int64_t n_missing = std::int64_t(missing.size());
    const int threads = options_.threads > 0 ? options_.threads : thread_count();
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
    for (std::int64_t m = 0; m < n_missing; ++m) {
      const std::size_t i = missing[std::size_t(m)];
      flags[i] = cell_flags(index.blocks[i], dilation, *transparency_, float(mapping.lo), float(mapping.scale()));
    }
    for (std::size_t i : missing) cache.insert(bricks[i].samples, flags[i]);
    local.cell_ranges_built = missing.size();
    for (std::size_t i = 0; i < bricks.size(); ++i) attach_flags(index.blocks[i], flags[i], local);
  }
  return cast(camera, index, mapping, t0, local, stats);
}

Image RayCaster::cast(const Camera& camera, const FrameIndex& index, const ValueMapping& mapping,
                      SteadyClock::time_point t0, RenderStats& local, RenderStats* stats) {
  std::vector<bool> used(std::size_t(index.max_level) + 1, false);
  for (const detail::Block& b : index.blocks) used[std::size_t(b.level)] = true;
  const std::vector<LevelParams> levels =
      level_params(tables_, tf_, options_, index.max_level, index.min_spacing, used);
  local.setup_ms = ms_since(t0);
  const auto t1 = SteadyClock::now();
  Image image = run({*transparency_, camera, index, options_, levels, float(mapping.lo), float(mapping.scale())}, local);
  local.raycast_ms = ms_since(t1);
  local.total_ms = ms_since(t0);
  if (stats) *stats = local;
  return image;
}

PreparedVolume::PreparedVolume(const Volume& volume, double value_min, double value_max)
    : index_(std::make_unique<FrameIndex>(detail::build_volume_index(volume))),
      value_min_(value_min),
      value_max_(value_max) {}
PreparedVolume::PreparedVolume(const Volume& volume)
    : index_(std::make_unique<FrameIndex>(detail::build_volume_index(volume))),
      value_min_(index_->blocks[0].value_lo),
      value_max_(index_->blocks[0].value_hi) {}
PreparedVolume::~PreparedVolume() = default;
PreparedVolume::PreparedVolume(PreparedVolume&&) noexcept = default;
PreparedVolume& PreparedVolume::operator=(PreparedVolume&&) noexcept = default;

Image RayCaster::render(const Camera& camera, const Volume& volume, double value_min, double value_max,
                        RenderStats* stats) {
  const auto t0 = SteadyClock::now();
  PreparedVolume prepared(volume, value_min, value_max);
  const double prepare_ms = ms_since(t0);
  Image image = render(camera, prepared, stats);
  if (stats) {
    stats->setup_ms += prepare_ms;
    stats->total_ms += prepare_ms;
  }
  return image;
}

Image RayCaster::render(const Camera& camera, PreparedVolume& volume, RenderStats* stats) {
  // The same traversal over a one-cell index: an empty brick list, the volume as block 0.
  const auto t0 = SteadyClock::now();
  FrameIndex& index = *volume.index_;
  detail::cull_blocks(index, tf_, volume.value_min_, volume.value_max_);
  const ValueMapping m = tf_.mapping(volume.value_min_, volume.value_max_);
  RenderStats local;
  Block& block = index.blocks[0];
  block.empty = nullptr;
  if (const int dilation = skip_dilation(options_); dilation && !block.culled) {
    if (!volume.flags_ || volume.flags_owner_ != id_) {
      volume.flags_ = cell_flags(block, dilation, *transparency_, float(m.lo), float(m.scale()));
      volume.flags_owner_ = id_;
      local.cell_ranges_built = 1;
    }
    attach_flags(block, volume.flags_, local);
  }
  local.bricks_in_frame = 1;
  local.bricks_culled = block.culled ? 1 : 0;
  return cast(camera, index, m, t0, local, stats);
}

nlohmann::json stats_json(const RenderStats& s, const lod::LoadStats* load) {
  nlohmann::json j;
  j["render"] = {{"rays", s.rays},
                 {"samples", s.samples},
                 {"bricks_in_frame", s.bricks_in_frame},
                 {"bricks_culled", s.bricks_culled},
                 {"bricks_sampled", s.bricks_sampled},
                 {"cells_empty", s.cells_empty},
                 {"cells_total", s.cells_total},
                 {"cell_ranges_built", s.cell_ranges_built},
                 {"setup_ms", s.setup_ms},
                 {"raycast_ms", s.raycast_ms},
                 {"total_ms", s.total_ms}};
  if (load)
    j["load"] = {{"selected", load->selected},     {"resident", load->resident},
                 {"cache_hits", load->cache_hits}, {"cache_misses", load->cache_misses},
                 {"bytes_read", load->bytes_read}, {"decode_ms", load->decode_ms},
                 {"pending", load->pending}};
  return j;
}

}  // namespace strata::render
