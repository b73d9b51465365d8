#pragma once
#include <utility>
// The per-frame spatial index of the ray caster: a grid over level-0 brick cells, each cell
// pointing at the block (a resident brick of any level, or a whole in-memory volume) that
// covers it, with every per-brick constant the sampling loop needs precomputed.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "render/occupancy.hpp"
#include "strata/core/volume.hpp"
#include "strata/render/raycaster.hpp"

namespace strata::render::detail {

struct Block {
  const float* data = nullptr;  // nullptr: every sample equals `constant`
  float constant = 0;
  std::array<int, 3> n{};       // samples per axis (x fastest)
  int level = 0;
  std::array<double, 3> lo{}, hi{};          // world box the block answers for (clipped to the volume)
  std::array<double, 3> scale{}, offset{};   // world -> local sample coordinates
  std::array<float, 3> gradient_scale{};     // local central difference -> world gradient
  float value_lo = 0, value_hi = 0;          // range of the samples
  bool culled = false;                       // transparent under the TF
  bool exclusive = true;                     // owns every cell its box covers (else walk cells)
  // Empty-space skipping (render/occupancy.hpp): one flag per macro-cell, non-zero where every
  // segment ending in the cell is transparent; nullptr = no cell is empty (or skipping is off).
  const std::uint8_t* empty = nullptr;
  std::array<int, 3> cells{1, 1, 1};

  bool empty_at(float x, float y, float z) const {
    constexpr float inv = 1.0f / float(kCell);
    const int cx = std::clamp(int(x * inv), 0, cells[0] - 1), cy = std::clamp(int(y * inv), 0, cells[1] - 1),
              cz = std::clamp(int(z * inv), 0, cells[2] - 1);
    return empty[(std::size_t(cz) * std::size_t(cells[1]) + std::size_t(cy)) * std::size_t(cells[0]) + std::size_t(cx)] != 0;
  }
};

struct FrameIndex {
  std::vector<Block> blocks;
  std::array<std::int64_t, 3> cells{1, 1, 1};
  std::array<double, 3> cell_size{};      // world size of one cell
  std::vector<std::int32_t> cell_block;   // -1 = empty
  std::array<double, 3> volume_hi{};      // world box [0, volume_hi]
  double min_spacing = 1;
  int max_level = 0;
  Volume owned;  // a non-float in-memory volume converted to float (its buffer moves with the index)

  std::int32_t block_at(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return cell_block[std::size_t((z * cells[1] + y) * cells[0] + x)];
  }
};

// The frame's bricks, culled under `tf` (cull_blocks with the frame's value range).
FrameIndex build_frame_index(const FrameInput& frame, const TransferFunction& tf);
// An in-memory volume as one block (its samples converted to float when they are not), not
// culled: independent of any transfer function, so it can serve many frames.
FrameIndex build_volume_index(const Volume& volume);
// Marks the blocks whose [min, max] is transparent under `tf` (normalised over
// [value_min, value_max]) as culled, and the others as not.
void cull_blocks(FrameIndex& index, const TransferFunction& tf, double value_min, double value_max);

/// The range of the finite ones of n samples: NaN and infinite voxels are empty space. Without
/// any, {+inf, -inf} (lo > hi: nothing to draw).
std::pair<float, float> finite_range(const float* v, std::size_t n);

}  // namespace strata::render::detail
