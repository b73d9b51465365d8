#pragma once
/// @file
/// @brief CPU ray casting of a label volume from its Mixture Graph palette (paper §4).
///
/// Per sample: the mip level comes from the pixel footprint (world size of one pixel at the
/// sample's view depth over the level-0 voxel size, log2, plus `lod_bias`); the sample is the
/// trilinear interpolation of the premultiplied palette colours of the 8 nearest voxels of
/// that level - pre-filtered, because each coarse voxel's colour is already the mean over its
/// footprint. The step length grows with the level (step x voxel size of the level) and the
/// opacity is corrected for it; compositing is front to back with early termination; empty
/// cubes of the scene's skip hierarchy (LabelScene) are jumped over whole.
///
/// World space as in strata/lod/view.hpp: level-0 voxel units times spacing. Label opacities
/// are per level-0 voxel thickness (the geometric mean of the spacing).
#include <cstdint>

#include <nlohmann/json_fwd.hpp>

#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"
#include "strata/render/label_color_map.hpp"
#include "strata/render/label_scene.hpp"
#include "strata/render/label_shading.hpp"

namespace strata::render {

/// @brief How shaded label frames are lit (paper 4, Fig. 7).
enum class LabelLighting {
  gradient,  ///< headlight from the gradient of the interpolated opacity, on the fly
  normals,   ///< pre-filtered light from the file's normals graph (label_shading.hpp)
};

/// @brief Sampling, level choice, lighting and scheduling of a label frame (checked by
/// render_labels).
struct LabelRenderOptions {
  double lod_bias = 0.0;       // added to the level from the footprint; > 0 = coarser, blurrier
  int finest_level = 0;        // never sample (or decode) finer than this level
  bool blend_levels = false;   // interpolate between the two nearest levels (else the nearest)
  double step = 0.5;           // step length in voxels of the sampled level, > 0
  double termination = 0.99;   // stop a ray once its accumulated opacity reaches this
  bool skip_empty = true;      // jump over cubes the opacity hierarchy proves transparent
  // Level 0 reconstructed by the cubic B-spline of the palette (64 voxels where labels meet,
  // one read inside a label) instead of trilinearly: zoomed in, label boundaries and their
  // lighting are smooth instead of the voxel staircase. Coarser levels are pre-filtered already.
  bool smooth = true;
  // Headlight shading from the opacity gradient (labels have no meaningful value gradient,
  // paper §4): colour x (ambient + (1 - ambient) |n . view|). Costs 6 extra palette samples
  // per visible sample.
  bool shading = false;
  LabelLighting lighting = LabelLighting::gradient;  // with shading
  double ambient = 0.35;
  double specular = 0.25, shininess = 24;  // normals lighting: white highlight, specular·|n·l|^shininess
  // Gradient lighting: also local ambient occlusion (paper Fig. 7, left): the light reaching a
  // sample along three short rays off the surface (4 samples each, one level voxel apart)
  // scales its shading. 12 more palette samples per visible sample.
  bool occlusion = false;
  LabelRgba background{0, 0, 0, 1};  // straight alpha
  int tile = 16;               // pixels per tile edge (tiles are the unit of parallel work)
};

/// @brief Counters and timings of one label frame, written by render_labels.
struct LabelRenderStats {
  double ms = 0;               // whole frame, including prepare work
  double march_ms = 0;         // ray marching only
  double palette_ms = 0;       // palette propagation in this frame (0 when the colours are unchanged)
  double ids_ms = 0;           // node-id decoding in this frame (0 once the levels are cached)
  double skip_grid_ms = 0;     // skip grids rebuilt in this frame
  std::uint64_t ids_decoded = 0;  // node ids (voxels) read from the file in this frame
  std::uint64_t rays = 0;         // rays that hit the volume's box
  std::uint64_t samples = 0;      // palette samples taken (each = 8 voxels of one level, x2 when blending)
  std::uint64_t skipped_cubes = 0;
  std::uint64_t terminated_rays = 0;  // stopped early by opacity
  int finest_level = 0, coarsest_level = 0;  // level range this frame may sample
};

/// @brief Renders `scene` as seen by `camera` (whose volume dims/spacing should be the scene's).
/// Calls scene.prepare() first, so the first frame decodes the needed levels' ids and later
/// frames only recompute what a colour-map change invalidated. Throws ParameterError naming the
/// LabelRenderOptions field on bad options (the step as check_step in sampling_limits.hpp), and
/// for normals lighting without `normals` (the file's normals graph). The normals light is a
/// headlight at infinity: towards the eye along the view direction. Casts on
/// strata::thread_count() OpenMP threads, tile by tile (src/render/traversal.hpp).
Image render_labels(LabelScene& scene, const Camera& camera, const LabelRenderOptions& options = {},
                    LabelRenderStats* stats = nullptr, LabelShading* normals = nullptr);

/// @brief A frame's statistics as the JSON `strata render --stats` writes: {"render": {...}}.
nlohmann::json stats_json(const LabelRenderStats& stats);

}  // namespace strata::render
