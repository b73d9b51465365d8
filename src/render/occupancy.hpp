#pragma once
// Empty-space skipping inside a block: the sample grid is cut into macro-cells of kCell^3
// positions, and each cell stores the [min, max] of every voxel that a trilinear sample at a
// position within `dilation` (L-infinity, local voxel units) of the cell can read. A segment
// between two consecutive lattice points is at most one local step long in every axis, so when
// the step is <= dilation, the whole segment ending in a cell takes its values in the cell's
// range; if the transfer function is zero over that range (pre-integrated or not), the segment
// contributes nothing and the ray caster may skip it without changing the image.
//
// The ranges are turned into one flag per cell under the ray caster's transfer function and
// value mapping (CellFlags, by cell_flags), computed once per brick and memoised (CellFlagCache)
// for as long as the brick's samples stay alive: 1 byte per 2^3 cell, 1/32 of the brick's float
// samples.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

namespace strata::render {
struct RenderOptions;
struct RenderStats;
}  // namespace strata::render

namespace strata::render::detail {

struct Block;
struct Transparency;

constexpr int kCell = 2;  // macro-cell edge in sample positions

struct CellRanges {
  std::array<int, 3> cells{};  // macro-cells per axis
  std::vector<float> lo, hi;   // per cell, x fastest
};

// Positions p in [0, n - 1] (clamped) map to cell min(floor(p / kCell), cells - 1). Cell c's range
// covers voxels [kCell c - dilation, kCell (c + 1) + dilation] clipped to the grid, which holds
// the trilinear footprint of every (clamped) position within `dilation` of the cell.
CellRanges compute_cell_ranges(const float* data, const std::array<int, 3>& n, int dilation);

struct CellFlags {
  std::array<int, 3> cells{};
  std::size_t empty_count = 0;
  std::vector<std::uint8_t> empty;  // per cell, x fastest (1 = transparent), then 3 bytes of padding
};

// Macro-cell dilation for a step (in local voxels): a segment is at most one step long per axis.
// 0 when skipping is off (RenderOptions::skip_cells) or the step is too long for it.
int skip_dilation(const RenderOptions& o);

// One flag per macro-cell of a block's samples: set where the (dilated) value range is
// transparent under the TF, i.e. where every segment ending in the cell is transparent.
std::shared_ptr<const CellFlags> cell_flags(const Block& b, int dilation, const Transparency& tr, float value_lo,
                                            float value_scale);

// Points block b at the flags (none when `f` is null) and counts its cells in `stats`.
void attach_flags(Block& b, const std::shared_ptr<const CellFlags>& f, RenderStats& stats);

// Flags of the bricks a frame samples, keyed by the samples' address and kept while the brick
// lives (an expired weak_ptr marks a dead brick whose address may have been reused). Entries
// are valid for one transfer function and dilation (the owning ray caster's) and one value
// mapping: `key` tells which.
class CellFlagCache {
 public:
  std::shared_ptr<const CellFlags> find(const std::shared_ptr<const std::vector<float>>& samples) const;
  void insert(const std::shared_ptr<const std::vector<float>>& samples, std::shared_ptr<const CellFlags> flags);
  void sweep();  // drops entries whose brick died
  void clear() { entries_.clear(); }
  std::array<double, 2> key{0, -1};  // value_lo, value_scale of the entries

 private:
  struct Entry {
    std::weak_ptr<const std::vector<float>> brick;
    std::shared_ptr<const CellFlags> flags;
  };
  std::unordered_map<const void*, Entry> entries_;
};

}  // namespace strata::render::detail
