#include "strata/core/stopwatch.hpp"
#include "strata/render/label_scene.hpp"

#include <algorithm>
#include <chrono>
#include <utility>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/mixture/palette.hpp"

namespace strata::render {

namespace {

// Below this many voxels a parallel region costs more than it saves.
constexpr std::int64_t kParallelVoxels = 1 << 16;

// One pass of a 3-wide max filter along an axis with stride `stride` and length `n` (the
// axis extent); separable, so three passes give the 3x3x3 dilation.
void dilate_axis(std::vector<std::uint8_t>& grid, const Extent& d, int axis) {
  const std::int64_t n = axis == 0 ? d.x : axis == 1 ? d.y : d.z;
  if (n < 2) return;
  const std::int64_t stride = axis == 0 ? 1 : axis == 1 ? d.x : d.x * d.y;
  const std::int64_t lines = d.voxel_count() / n;
  std::vector<std::uint8_t> src = grid;
#pragma omp parallel for schedule(static) num_threads(thread_count()) if (lines * n > kParallelVoxels)
  for (std::int64_t line = 0; line < lines; ++line) {
    // The first voxel of a line: lines enumerate the other two axes, x fastest.
    std::int64_t base = 0;
    if (axis == 0) base = line * d.x;
    else if (axis == 1) base = (line / d.x) * d.x * d.y + line % d.x;
    else base = line;
    for (std::int64_t i = 0; i < n; ++i) {
      const std::int64_t at = base + i * stride;
      std::uint8_t v = src[std::size_t(at)];
      if (i > 0) v |= src[std::size_t(at - stride)];
      if (i + 1 < n) v |= src[std::size_t(at + stride)];
      grid[std::size_t(at)] = v;
    }
  }
}

}  // namespace

LabelScene::LabelScene(const mixture::EncodedLabels& labels, LabelColorMap colors)
    : labels_(labels), colors_(std::move(colors)) {
  levels_.resize(std::size_t(labels_.level_count()));
  for (int l = 0; l < labels_.level_count(); ++l) levels_[std::size_t(l)].dims = labels_.level_dims(l);
}

void LabelScene::set_color_map(LabelColorMap colors) {
  colors_ = std::move(colors);
  palette_stale_ = true;
}

bool LabelScene::anything_visible() const {
  // The coarsest level is one voxel whose node mixes every label of the volume.
  const Level& top = levels_.back();
  if (!top.decoded || visible_.empty()) throw Error("LabelScene: anything_visible() before prepare()");
  return visible_[top.ids[0]] != 0;
}

LabelPrepareReport LabelScene::prepare(int finest_level, bool skip_grids) {
  if (finest_level < 0 || finest_level >= level_count())
    throw Error(labels_.name() + ": level " + std::to_string(finest_level) + " is not in 0.." +
                std::to_string(level_count() - 1));
  LabelPrepareReport report;
  if (palette_stale_) {
    const auto start = std::chrono::steady_clock::now();
    rebuild_palette();
    report.palette_ms = ms_since(start);
  }
  for (int l = finest_level; l < level_count(); ++l) {
    Level& level = levels_[std::size_t(l)];
    if (!level.decoded) {
      const auto start = std::chrono::steady_clock::now();
      decode_level(level, l);
      report.ids_ms += ms_since(start);
      report.id_voxels_decoded += level.ids.size();
    }
    if (skip_grids && l >= kFinestSkipLevel && level.skip_generation != palette_generation_) {
      const auto start = std::chrono::steady_clock::now();
      build_skip_grid(level);
      report.skip_ms += ms_since(start);
    }
  }
  return report;
}

void LabelScene::rebuild_palette() {
  const mixture::MixtureGraph& g = labels_.graph();
  const std::vector<float> sources = colors_.premultiplied_sources(labels_.label_map());
  palette_ = mixture::propagate_palette(g, labels_.schedule(), sources, 4);

  // Conservative visibility: predecessors always have smaller ids, so one ascending scan.
  visible_.assign(std::size_t(g.node_count()), 0);
  for (std::uint32_t s = 0; s < g.num_sources; ++s) visible_[s] = sources[std::size_t(s) * 4 + 3] > 0.0f;
  for (std::size_t i = 0; i < g.nodes.size(); ++i) {
    const mixture::InternalNode& n = g.nodes[i];
    visible_[g.num_sources + i] = visible_[n.a] | visible_[n.b];
  }
  ++palette_generation_;
  ++palette_builds_;
  palette_stale_ = false;
}

void LabelScene::decode_level(Level& level, int index) {
  level.ids.resize(std::size_t(level.dims.voxel_count()));
  // EncodedLabels checked every stored id against the node count when it opened the file, so
  // the ids can index palette_ and visible_ as they are.
  labels_.decode_box(index, Box::whole(level.dims), level.ids);
  level.decoded = true;
  id_voxels_decoded_ += level.ids.size();
}

void LabelScene::build_skip_grid(Level& level) const {
  level.occupied.resize(level.ids.size());
  const std::int64_t n = std::int64_t(level.ids.size());
#pragma omp parallel for schedule(static) num_threads(thread_count()) if (n > kParallelVoxels)
  for (std::int64_t i = 0; i < n; ++i) level.occupied[std::size_t(i)] = visible_[level.ids[std::size_t(i)]];
  for (int axis = 0; axis < 3; ++axis) dilate_axis(level.occupied, level.dims, axis);
  level.skip_generation = palette_generation_;
}

}  // namespace strata::render
