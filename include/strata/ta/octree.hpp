#pragma once
// Geometry of the bricked multiresolution octree (paper 1, §3). Every level is a regular grid
// of bricks of width B; a brick stores its `core` = B - 2*overlap voxels plus `overlap` voxels
// of its neighbours on each side, so trilinear interpolation and gradients never need a second
// brick. Level 0 samples the input; level l+1 halves level l (2x2x2 averages of the decoded
// level l, odd extents rounded up) until one brick covers the whole level.
#include <cstdint>
#include <vector>

#include "strata/core/extent.hpp"
#include "strata/core/volume.hpp"

namespace strata::ta {

struct BrickLayout {
  int brick = 32;   // B: stored width including overlap
  int overlap = 2;  // voxels shared with each neighbour, per side

  int core() const { return brick - 2 * overlap; }
  // Throws ParameterError("BrickLayout::brick") unless 2 <= brick <= 256, and
  // ParameterError("BrickLayout::overlap") unless 0 <= overlap and 1 <= core.
  void validate() const;
};

struct LevelGeometry {
  Extent dims;    // voxels of this level
  Extent bricks;  // brick grid (ceil(dims / core))
};

class OctreeGeometry {
 public:
  OctreeGeometry(const Extent& volume_dims, const BrickLayout& layout);

  const BrickLayout& layout() const { return layout_; }
  int level_count() const { return int(levels_.size()); }
  const LevelGeometry& level(int l) const { return levels_.at(std::size_t(l)); }
  std::int64_t total_bricks() const;
  /// @brief Brick (bx, by, bz) of `level` in octree order: the bricks of finer levels first,
  /// then x fastest within the level (the ta-global feature-scale table's row order). With
  /// `within_level`, its position in its own level only.
  std::int64_t brick_ordinal(int level, std::int64_t bx, std::int64_t by, std::int64_t bz, bool within_level = false) const;

  // Voxels of `level` whose samples a brick stores: its core box shifted by -overlap and grown
  // by 2*overlap. May extend past the level's edges; those samples are clamped to the edge.
  Box brick_sample_box(int level, std::int64_t bx, std::int64_t by, std::int64_t bz) const;
  // The brick's own (non-overlapping) voxels, clipped to the level.
  Box brick_core_box(int level, std::int64_t bx, std::int64_t by, std::int64_t bz) const;

 private:
  BrickLayout layout_;
  std::vector<LevelGeometry> levels_;
  std::vector<std::int64_t> first_brick_;  // octree ordinal of each level's first brick
};

// Extent of the next coarser level: ceil(d / 2) per axis.
Extent half_extent(const Extent& d);
/// @brief The next coarser level of an f32 volume as the octree builds it: 2×2×2 means, an odd
/// last column, row or slice pairing with itself; a cell's non-finite voxels are left out
/// unless all are (then its first voxel's value). Dims half_extent(v.dims()).
Volume half_resolution(const Volume& v);

}  // namespace strata::ta
