#pragma once
/// @file
/// @brief A label volume ready for rendering from its Mixture Graph (paper §3.4, §4).
///
/// Two kinds of state with different lifetimes:
/// * node ids per mip level - the "brick payload" of a label file. Decoded from the
///   EncodedLabels once per level, on first need, and kept; never read again.
/// * everything derived from the colour map: the palette (premultiplied RGBA per graph node,
///   by propagating the per-label colours through the DAG - the pre-filtered colour of every
///   voxel of every level), a conservative per-node visibility, and per level a skip grid.
///   A colour-map change only marks these stale; prepare() rebuilds them from cached ids.
///
/// Empty-space skipping: the palette's alpha is the mean label opacity of a voxel's footprint
/// (the paper's opacity mipmap). For the skip decision we also propagate the MAXIMUM opacity
/// (a node is visible if either predecessor is): mean opacity is zero exactly when all labels
/// are transparent only while every interpolation weight is non-zero, and a 20-bit codebook
/// can round a tiny weight to 0. A level-l voxel is "empty" when no visible node lies in its
/// 3x3x3 neighbourhood, because trilinear sampling at any level <= l inside the voxel's cube
/// reads voxels within one level-l voxel of the sample: the ray may then skip the whole cube.
/// Skip grids start at level 1 (kFinestSkipLevel).
///
/// Not thread-safe for mutation: set_color_map() and prepare() must not overlap a render; the
/// accessors used while rendering are const and read-only.
#include <cstdint>
#include <span>
#include <vector>

#include "strata/core/extent.hpp"
#include "strata/core/volume.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/label_color_map.hpp"

namespace strata::render {

/// @brief What one prepare() call did (the per-frame part of the render stats).
struct LabelPrepareReport {
  double palette_ms = 0;          // palette + visibility propagation (0 when unchanged)
  double ids_ms = 0;              // decoding node ids of newly needed levels
  double skip_ms = 0;             // building skip grids
  std::uint64_t id_voxels_decoded = 0;
};

/// @brief A label file's node ids per level (decoded once) and what the colour map makes of
/// them (palette, visibility, skip grids), as the label ray caster reads them.
class LabelScene {
 public:
  /// @brief Skip grids exist for levels >= this: a level-0 grid would cost a byte per voxel and
  /// a full pass per colour change to skip single voxels, which is hardly cheaper than sampling.
  static constexpr int kFinestSkipLevel = 1;

  /// @brief Keeps a reference: `labels` must outlive the scene. Decodes nothing yet.
  explicit LabelScene(const mixture::EncodedLabels& labels, LabelColorMap colors = {});

  int level_count() const { return int(levels_.size()); }
  Extent level_dims(int level) const { return levels_.at(std::size_t(level)).dims; }
  Extent dims() const { return level_dims(0); }
  Spacing spacing() const { return labels_.spacing(); }

  /// @brief A new colour map; takes effect at the next prepare() (node ids stay cached).
  void set_color_map(LabelColorMap colors);

  /// @brief Makes levels finest..level_count()-1 renderable for the current colour map:
  /// decodes the ids of levels not yet cached, rebuilds the palette if the colour map changed,
  /// and (with skip_grids) the skip grids that are missing or stale. Throws Error when
  /// `finest_level` is not a level.
  LabelPrepareReport prepare(int finest_level, bool skip_grids = true);

  /// @brief Valid after prepare(): premultiplied RGBA per node (4 floats per node id).
  std::span<const float> palette() const { return palette_; }
  /// @brief Node ids of a prepared level, x fastest.
  std::span<const std::uint32_t> level_ids(int level) const { return levels_.at(std::size_t(level)).ids; }
  /// @brief Per voxel of a prepared level >= kFinestSkipLevel (empty below): 1 when a visible
  /// node lies in its 3x3x3 neighbourhood.
  std::span<const std::uint8_t> occupied(int level) const { return levels_.at(std::size_t(level)).occupied; }
  /// @brief Whether any label of the volume is visible under the current (prepared) colour
  /// map. Throws Error before prepare().
  bool anything_visible() const;

  /// @brief Totals since construction (tests assert that colour changes decode no ids).
  std::uint64_t id_voxels_decoded() const { return id_voxels_decoded_; }
  std::uint64_t palette_builds() const { return palette_builds_; }

 private:
  struct Level {
    Extent dims;
    std::vector<std::uint32_t> ids;      // empty until decoded
    std::vector<std::uint8_t> occupied;  // skip grid for palette generation `skip_generation`
    std::uint64_t skip_generation = 0;
    bool decoded = false;
  };

  void rebuild_palette();
  void decode_level(Level& level, int index);
  void build_skip_grid(Level& level) const;

  const mixture::EncodedLabels& labels_;
  LabelColorMap colors_;
  std::vector<Level> levels_;
  std::vector<float> palette_;
  std::vector<std::uint8_t> visible_;  // per node: some label in its footprint has opacity > 0
  std::uint64_t palette_generation_ = 0;  // 0 = never built
  bool palette_stale_ = true;
  std::uint64_t id_voxels_decoded_ = 0, palette_builds_ = 0;
};

}  // namespace strata::render
