#pragma once
// The per-frame level-of-detail cut through the brick octree (paper 1, §3 and §6.1): starting
// at the root, a brick is replaced by its children while one of its voxels covers more than
// `lod` pixels, it intersects the view frustum and some of its values are visible under the
// transfer function. Bricks outside the frustum or empty under the transfer function are
// dropped. Refinement is greedy, largest projected voxel first, so it runs coarse to fine and,
// within a level, nearest first; when a budget would be exceeded the brick stays coarse.
#include <cstdint>
#include <vector>

#include "strata/lod/view.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::lod {

struct SelectionOptions {
  double lod = 1.0;                          // refine while a voxel spans more pixels than this
  std::int64_t max_bricks = 8192;            // bricks in the cut
  std::uint64_t memory_budget = 1ull << 30;  // bytes of reconstructed (non-constant) bricks, B^3 floats each
  void validate(int brick_width) const;      // throws Error: lod > 0, max_bricks >= 1, budget >= one brick
};

struct CutBrick {
  store::BrickKey key;
  const store::BrickEntry* entry = nullptr;  // into the volume's index (lives as long as the TaVolume)
  double depth = 0;                          // nearest point along the view direction (view_depth)
  double pixels_per_voxel = 0;               // projected voxel edge at `depth`
  // False when the brick's own samples are all invisible under the transfer function while
  // finer bricks below it are not (thin structures averaged away): it is refined, never drawn.
  bool content_visible = true;
};

struct Selection {
  std::vector<CutBrick> bricks;             // in refinement order: coarse and near first
  std::vector<std::int64_t> per_level;      // bricks of the cut per level (index = level)
  std::uint64_t bytes = 0;                  // reconstructed bytes the cut needs (constant bricks: 0)
  bool brick_budget_hit = false, memory_budget_hit = false;
  std::int64_t culled_frustum = 0, culled_empty = 0;  // bricks examined and dropped
  bool budget_hit() const { return brick_budget_hit || memory_budget_hit; }
};

// Bytes a reconstructed brick occupies (B^3 floats); constant bricks need none.
std::uint64_t reconstructed_bytes(const store::BrickEntry& entry, int brick_width);

// `visible_bins`: histogram bins (histogram_bins.hpp) with non-zero opacity; 0 selects nothing.
// Throws Error on an unusable view (non-positive pixel size) or invalid options.
Selection select_cut(const ta::TaVolume& volume, const View& view, std::uint64_t visible_bins,
                     const SelectionOptions& options = {});

}  // namespace strata::lod
