// The classification tables of each level (level_tables.hpp): the transfer function's
// pre-integrated table, regrouped into the bilinear cells the march reads, or its
// post-classification lookup table, at the level's step ratio.
#include "render/level_tables.hpp"

#include <cmath>
#include <cstddef>
#include <memory>
#include <utility>

#include "render/ray_sampling.hpp"
#include "render/shading.hpp"

namespace strata::render::detail {

namespace {

// The pre-integrated table regrouped into bilinear cells (Classifier::cells).
std::vector<float> bilinear_cells(const PreintegratedTable& t) {
  const std::size_t n = std::size_t(t.size), m = n - 1;
  std::vector<float> cells(m * m * 16);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < m; ++j) {
      float* c = cells.data() + (i * m + j) * 16;
      const Rgbaf* corners[4] = {&t.entries[i * n + j], &t.entries[(i + 1) * n + j], &t.entries[i * n + j + 1],
                                 &t.entries[(i + 1) * n + j + 1]};
      for (int q = 0; q < 4; ++q) {
        c[4 * q + 0] = corners[q]->r;
        c[4 * q + 1] = corners[q]->g;
        c[4 * q + 2] = corners[q]->b;
        c[4 * q + 3] = corners[q]->a;
      }
    }
  return cells;
}

}  // namespace

std::vector<LevelParams> level_params(std::vector<std::unique_ptr<LevelTables>>& tables,
                                      const TransferFunction& tf, const RenderOptions& options, int max_level,
                                      double min_spacing, const std::vector<bool>& used) {
  std::vector<LevelParams> levels(std::size_t(max_level) + 1);
  if (tables.size() < levels.size()) tables.resize(levels.size());
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const double ratio = options.step * std::ldexp(1.0, int(l));
    levels[l].h = ratio * min_spacing;
    levels[l].shade_threshold = correct_opacity(kShadeThreshold, ratio);
    if (l >= used.size() || !used[l]) continue;
    if (!tables[l]) {
      auto t = std::make_unique<LevelTables>();
      if (options.preintegrated) {
        t->cells = bilinear_cells(tf.preintegrated_table(options.table_size, ratio));
      } else {
        t->lookup = tf.lookup_table(16 * options.table_size, ratio);
      }
      tables[l] = std::move(t);
    }
    const LevelTables& t = *tables[l];
    // The pre-integrated table is options.table_size^2 entries (read through its cells only).
    levels[l].classify = options.preintegrated
                             ? Classifier{nullptr, options.table_size, float(options.table_size - 1), t.cells.data()}
                             : Classifier{t.lookup.entries.data(), t.lookup.size, float(t.lookup.size - 1)};
  }
  return levels;
}

}  // namespace strata::render::detail
