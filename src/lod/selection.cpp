#include "strata/lod/selection.hpp"

#include <cmath>
#include <queue>
#include <string>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/lod/brick_bounds.hpp"
#include "strata/lod/histogram_bins.hpp"

namespace strata::lod {

void SelectionOptions::validate(int brick_width) const {
  if (!(lod > 0)) throw Error("lod selection: the lod threshold must be positive, got " + std::to_string(lod));
  if (max_bricks < 1) throw Error("lod selection: the brick budget must be at least 1");
  const std::uint64_t one = std::uint64_t(brick_width) * brick_width * brick_width * sizeof(float);
  if (memory_budget < one)
    throw Error("lod selection: the memory budget of " + std::to_string(memory_budget) +
                " bytes is below one reconstructed brick (" + std::to_string(one) + " bytes)");
  if (!(std::isfinite(feature_scale) && feature_scale >= 0 && feature_scale <= 1))
    throw Error(fmt::format("lod selection: the feature scale is a normalized RMSE in [0, 1] (0 = off), got {}",
                            feature_scale));
}

std::uint64_t reconstructed_bytes(const store::BrickEntry& entry, int brick_width) {
  if (entry.kind == store::PayloadKind::constant) return 0;
  return std::uint64_t(brick_width) * brick_width * brick_width * sizeof(float);
}

namespace {

void check_view(const View& view) {
  const double size = view.perspective ? view.pixel_angle : view.pixel_world;
  if (!(size > 0))
    throw Error(std::string("lod selection: view.") + (view.perspective ? "pixel_angle" : "pixel_world") +
                " must be positive");
}

// Larger projected voxels first; equal ones (all bricks of a level in orthographic views)
// nearest first.
struct Refinement {
  bool operator()(const CutBrick& a, const CutBrick& b) const {
    if (a.pixels_per_voxel != b.pixels_per_voxel) return a.pixels_per_voxel < b.pixels_per_voxel;
    return a.depth > b.depth;
  }
};

class CutBuilder {
 public:
  CutBuilder(const ta::TaVolume& volume, const View& view, std::uint64_t visible_bins, const SelectionOptions& options)
      : volume_(volume), view_(view), near_(near_distance(view)), bins_(visible_bins), options_(options),
        width_(volume.geometry().layout().brick),
        target_rmse_(options.feature_scale * (volume.value_max() - volume.value_min())) {
    cut_.per_level.assign(std::size_t(volume.geometry().level_count()), 0);
  }

  Selection build() {
    if (bins_ != 0) {
      const int top = volume_.geometry().level_count() - 1;
      const Extent grid = volume_.geometry().level(top).bricks;
      std::vector<CutBrick> roots;
      Culled culled;
      for (std::int32_t z = 0; z < grid.z; ++z)
        for (std::int32_t y = 0; y < grid.y; ++y)
          for (std::int32_t x = 0; x < grid.x; ++x) examine({std::uint8_t(top), x, y, z}, roots, culled);
      admit(roots, culled);
      refine();
    }
    return std::move(cut_);
  }

 private:
  struct Culled {
    std::int64_t frustum = 0, empty = 0;
  };

  // Appends the brick to `out` unless it is culled (then counts why in `culled`).
  void examine(const store::BrickKey& key, std::vector<CutBrick>& out, Culled& culled) const {
    const store::BrickEntry* entry = &volume_.entry(key);
    const WorldBox box = brick_world_box(volume_.geometry(), volume_.source_info().spacing, key);
    if (!in_frustum(view_, box)) {
      ++culled.frustum;
      return;
    }
    // A brick is culled only when neither it nor any finer brick it covers can be visible.
    if ((volume_.subtree_histogram(key) & bins_) == 0) {
      ++culled.empty;
      return;
    }
    const double depth = view_depth(view_, box, near_);
    out.push_back({key, entry, depth, voxel_edge(volume_.source_info().spacing, key.level) / view_.pixel_size_at(depth),
                   brick_visible(*entry, bins_, volume_.value_min(), volume_.value_max()), feature_rank(key)});
  }

  bool feature_scale() const { return options_.feature_scale > 0; }

  // Alg. 2, line 16: the lowest ladder rank whose stored RMSE meets the target (else the full one).
  int feature_rank(const store::BrickKey& key) const {
    if (!feature_scale()) return 0;
    const std::span<const float> errors = volume_.rank_errors(key);
    const std::vector<int>& ladder = volume_.feature_scale_ladder();
    for (std::size_t i = 0; i < errors.size(); ++i)
      if (errors[i] <= target_rmse_) return ladder[i];
    return ladder.back();
  }

  // Whether a drawable brick stays in the cut: the screen-space rule, or with a feature scale
  // Alg. 2, line 12 (the lowest rank meets the target: never refined; the full rank meets it:
  // refined only while large on screen; otherwise always refined).
  bool fine_enough(const CutBrick& brick) const {
    const bool small = brick.pixels_per_voxel <= options_.lod;
    if (!feature_scale()) return small;
    const std::span<const float> errors = volume_.rank_errors(brick.key);
    return errors.front() <= target_rmse_ || (errors.back() <= target_rmse_ && small);
  }

  void admit(const std::vector<CutBrick>& bricks, const Culled& culled) {
    for (const CutBrick& b : bricks) {
      queue_.push(b);
      ++count_;
      bytes_ += reconstructed_bytes(*b.entry, width_);
    }
    cut_.culled_frustum += culled.frustum;
    cut_.culled_empty += culled.empty;
  }

  void refine() {
    while (!queue_.empty()) {
      const CutBrick brick = queue_.top();
      queue_.pop();
      // A brick whose own samples are invisible is refined whatever its size on screen (its
      // children hold what its averages lost); if the budgets forbid that, it is dropped.
      const bool stays = brick.content_visible && fine_enough(brick);
      if (brick.key.level == 0 || stays || !try_split(brick)) {
        if (brick.content_visible) {
          keep(brick);
        } else {
          --count_;
          bytes_ -= reconstructed_bytes(*brick.entry, width_);
          ++cut_.culled_empty;
        }
      }
    }
  }

  // Replaces `brick` by its visible children when both budgets allow it. The cut holds every
  // queued brick, so the budgets bound the queue plus the kept bricks at every step.
  bool try_split(const CutBrick& brick) {
    std::vector<CutBrick> children;
    Culled culled;
    for_each_child(brick.key, [&](const store::BrickKey& k) { examine(k, children, culled); });
    const std::uint64_t parent_bytes = reconstructed_bytes(*brick.entry, width_);
    std::uint64_t child_bytes = 0;
    for (const CutBrick& c : children) child_bytes += reconstructed_bytes(*c.entry, width_);
    if (count_ - 1 + std::int64_t(children.size()) > options_.max_bricks) {
      cut_.brick_budget_hit = true;
      return false;
    }
    if (bytes_ - parent_bytes + child_bytes > options_.memory_budget) {
      cut_.memory_budget_hit = true;
      return false;
    }
    --count_;
    bytes_ -= parent_bytes;
    admit(children, culled);
    return true;
  }

  template <class F>
  void for_each_child(const store::BrickKey& key, F&& f) const {
    const int level = key.level - 1;
    const Extent grid = volume_.geometry().level(level).bricks;
    for (int dz = 0; dz < 2; ++dz)
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const std::int64_t x = 2 * std::int64_t(key.x) + dx, y = 2 * std::int64_t(key.y) + dy,
                             z = 2 * std::int64_t(key.z) + dz;
          // Odd level extents leave the last parent with a single child along that axis.
          if (x < grid.x && y < grid.y && z < grid.z)
            f(store::BrickKey{std::uint8_t(level), std::int32_t(x), std::int32_t(y), std::int32_t(z)});
        }
  }

  void keep(const CutBrick& brick) {
    cut_.bricks.push_back(brick);
    ++cut_.per_level[brick.key.level];
    if (brick.rank > 0) ++cut_.per_rank[brick.rank];
    cut_.bytes += reconstructed_bytes(*brick.entry, width_);
  }

  const ta::TaVolume& volume_;
  const View& view_;
  double near_;  // near_distance(view_)
  std::uint64_t bins_;
  const SelectionOptions& options_;
  int width_;
  double target_rmse_;  // the feature scale in the file's units
  Selection cut_;
  std::priority_queue<CutBrick, std::vector<CutBrick>, Refinement> queue_;
  std::int64_t count_ = 0;   // bricks queued or kept
  std::uint64_t bytes_ = 0;  // their reconstructed bytes
};

}  // namespace

Selection select_cut(const ta::TaVolume& volume, const View& view, std::uint64_t visible_bins,
                     const SelectionOptions& options) {
  options.validate(volume.geometry().layout().brick);
  check_view(view);
  if (options.feature_scale > 0 && !volume.global())
    throw ParameterError("feature_scale", volume.container().name() + ": a feature scale needs the feature-scale table of a " +
                                              ta::kGlobalCodecName + " file (compress with --codec " +
                                              ta::kGlobalCodecName + "), or 0 for the screen-space rule alone");
  return CutBuilder(volume, view, visible_bins, options).build();
}

}  // namespace strata::lod
