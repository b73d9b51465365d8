#pragma once
/// @file
/// @brief The per-frame level-of-detail cut through the brick octree (paper 1, §3 and §6.1): starting
/// at the root, a brick is replaced by its children while one of its voxels covers more than
/// `lod` pixels, it intersects the view frustum and some of its values are visible under the
/// transfer function. Bricks outside the frustum or empty under the transfer function are
/// dropped. Refinement is greedy, largest projected voxel first, so it runs coarse to fine and,
/// within a level, nearest first; when a budget would be exceeded the brick stays coarse.
///
/// With a feature scale (ta-global files, paper 2 §5, Alg. 2) one error target ε couples
/// resolution and rank through the file's feature-scale table: each brick gets the lowest ladder
/// rank whose stored RMSE meets ε; a brick whose lowest rank meets ε is not refined however large
/// it is on screen (the minimum error front), one whose full rank misses ε is refined however small
/// (the maximum error front), and between the two the screen-space rule decides.
#include <cstdint>
#include <map>
#include <vector>

#include "strata/lod/view.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::lod {

/// @brief The screen-space threshold, the budgets and the feature scale of a cut.
struct SelectionOptions {
  double lod = 1.0;                          // refine while a voxel spans more pixels than this
  std::int64_t max_bricks = 8192;            // bricks in the cut
  std::uint64_t memory_budget = 1ull << 30;  // bytes of reconstructed (non-constant) bricks, B^3 floats each
  /// @brief ε_target of Alg. 2 as a normalized RMSE (RMSE / the file's value range); 0 = off.
  double feature_scale = 0;
  /// @brief Throws Error: lod > 0, max_bricks >= 1, budget >= one brick, feature_scale finite in [0, 1].
  void validate(int brick_width) const;
};

/// @brief One brick of the cut, with the figures the provider and the renderer use.
struct CutBrick {
  store::BrickKey key;
  const store::BrickEntry* entry = nullptr;  // into the volume's index (lives as long as the TaVolume)
  double depth = 0;                          // nearest point along the view direction (view_depth)
  double pixels_per_voxel = 0;               // projected voxel edge at `depth`
  /// @brief False when the brick's own samples are all invisible under the transfer function while
  /// finer bricks below it are not (thin structures averaged away): it is refined, never drawn.
  bool content_visible = true;
  /// @brief With a feature scale: the ladder rank whose stored error meets it (the full rank when none
  /// does); 0 otherwise (the frame's rank).
  int rank = 0;
};

/// @brief The cut of one frame and its statistics.
struct Selection {
  std::vector<CutBrick> bricks;             // in refinement order: coarse and near first
  std::vector<std::int64_t> per_level;      // bricks of the cut per level (index = level)
  std::map<int, std::int64_t> per_rank;     // with a feature scale: bricks of the cut per chosen rank
  std::uint64_t bytes = 0;                  // reconstructed bytes the cut needs (constant bricks: 0)
  bool brick_budget_hit = false, memory_budget_hit = false;
  std::int64_t culled_frustum = 0, culled_empty = 0;  // bricks examined and dropped
  bool budget_hit() const { return brick_budget_hit || memory_budget_hit; }
};

/// @brief Bytes a reconstructed brick occupies (B^3 floats); constant bricks need none.
std::uint64_t reconstructed_bytes(const store::BrickEntry& entry, int brick_width);

/// @brief The cut of one frame of `volume` seen through `view`.
/// `visible_bins`: histogram bins (histogram_bins.hpp) with non-zero opacity; 0 selects nothing.
/// Throws Error on an unusable view (non-positive pixel size) or invalid options, and
/// ParameterError("feature_scale") for a feature scale on a file without a feature-scale table.
Selection select_cut(const ta::TaVolume& volume, const View& view, std::uint64_t visible_bins,
                     const SelectionOptions& options = {});

}  // namespace strata::lod
