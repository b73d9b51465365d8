#pragma once
// The ray caster's classification per level of detail: each level's world step and the
// transfer-function tables its samples are classified with, built for that level's step ratio
// and kept by the RayCaster (RayCaster::tables_) across frames.
#include <memory>
#include <vector>

#include "render/ray_traversal.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/transfer_function.hpp"

namespace strata::render::detail {

// Classification tables of one level: the step ratio h_l / reference differs per level.
struct LevelTables {
  std::vector<float> cells;  // the pre-integrated table as bilinear cells (Classifier::cells)
  LookupTable lookup;
};

// Levels 0..max_level: world step, and classification tables for the levels `used` marks
// (built into `tables` on first use; the step ratio, and so the table, differs per level).
// A level no block of the frame holds gets no table: building one costs tens of milliseconds,
// which a first frame drawn from the top level alone should not pay for every level.
std::vector<LevelParams> level_params(std::vector<std::unique_ptr<LevelTables>>& tables,
                                      const TransferFunction& tf, const RenderOptions& options, int max_level,
                                      double min_spacing, const std::vector<bool>& used);

}  // namespace strata::render::detail
