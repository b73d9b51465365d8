#pragma once
// CPU ray caster over reconstructed bricks (paper 1 §3: the renderer works on decoded bricks,
// with pre-integrated 1D transfer functions).
//
// Sampling. Each sample lies on a per-ray lattice t = k * h_l (t measured from the ray origin),
// h_l = step * 2^l * min(spacing) for a brick of level l, so a coarse level takes
// proportionally longer world steps; opacities are corrected for h_l against the reference step
// of one level-0 voxel. Trilinear interpolation and central-difference gradients read only the
// sampled brick: its 2-voxel overlap holds the neighbours' voxels, so bricks of one level join
// without seams (the "over-represented sub-volumes" case of deferred filtering: no second
// brick is ever read per sample). A segment that crosses a brick face is classified from the
// last sample of one brick and the first of the next, exactly as inside a brick.
//
// Between levels (paper 1 §6.3: interblock interpolation / deferred filtering would be needed
// for C0 continuity): coverage has no holes, because the frame index assigns every level-0
// brick cell to exactly one brick (the finest resident one) and the segment crossing a level
// change is composited with its true length (opacity corrected from the new level's step).
// The field itself may jump by the difference between a level and its 2x2x2 average; that
// value step, not a crack, is what can remain visible at a level boundary.
//
// Empty space: cells without a brick are skipped whole, as are bricks whose [min, max] maps to
// zero opacity (TransferFunction::visible). When the ray leaves a brick into skipped space it
// still composites the one segment that starts inside the brick (sampled from its overlap), so
// skipping never changes the image for step <= overlap - 0.5. Inside a visible brick, macro-cells
// of 2^3 samples whose value range (dilated by the step, render/occupancy.hpp) is transparent
// are skipped too: a lattice point is sampled only when the segment ending there can be
// visible, and the sample before it is taken afresh when it was skipped, so the composited
// segments are exactly those a full march composites with non-zero opacity (the flags are
// computed once per brick, 1 byte per cell, and memoised while the brick lives: the cache
// holds a weak_ptr, so it never keeps samples alive, and drops dead entries every frame).
//
// Speed. On CPUs with AVX2 (checked at run time; the build stays portable x86-64) the march
// inside a brick takes 8 lattice points at a time: trilinear taps, transparency bins, table
// coordinates, the 32-voxel central-difference stencil and Blinn-Phong by gathers and 8-wide
// arithmetic, with the scalar march's per-sample operations in the same order and without FMA.
// The 8 segments are then composited at once: the transmittance in front of each is a prefix
// product of (1 - alpha), so the ray's loop-carried chain is one update per chunk. That
// reassociation moves a pixel by at most one level against the scalar march (tests compare
// them). On CPUs with AVX-512 (F/VL/BW/DQ) the same loop runs from a second build of its source
// (render/march8_body.hpp) for that ISA: 32 vector registers spill less; the image is identical.
// The shading gradient equals the six trilinear taps f(p +- e_a) but reads each voxel once.
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "strata/core/stopwatch.hpp"
#include "strata/core/volume.hpp"
#include "strata/lod/frame_bricks.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"
#include "strata/render/transfer_function.hpp"
#include "strata/ta/octree.hpp"

namespace strata::store {
class ContainerReader;
}
namespace strata::ta {
class TaVolume;
}

namespace strata::render {

namespace detail {
class CellFlagCache;
struct LevelTables;  // per-level classification tables (raycaster.cpp)
struct CellFlags;
struct FrameIndex;
struct Transparency;
}

struct ShadingParams {
  float ambient = 0.3f, diffuse = 0.7f, specular = 0.25f;
  int shininess = 24;  // Blinn-Phong exponent (integer: evaluated by repeated squaring)
};

struct RenderOptions {
  double step = 0.5;            // sample distance in voxels of the sampled brick's level
  bool shading = true;          // Blinn-Phong with a headlight, central-difference gradients
  ShadingParams light;
  bool preintegrated = true;    // pre-integrated pairs (else post-classified lookup table)
  int table_size = 256;         // pre-integrated table is size^2; lookup table 16 * size
  std::array<float, 4> background{0, 0, 0, 1};  // straight RGBA
  float termination_alpha = 0.99f;  // early ray termination
  int threads = 0;              // 0 = strata::thread_count()
  int tile = 16;                // tile edge in pixels (dynamic OpenMP schedule over tiles)
  bool skip_cells = true;       // empty-space skipping inside bricks (exact; off for comparisons)
  bool simd = true;             // AVX2 inner loop when the CPU has it (same arithmetic as scalar)
  bool avx512 = true;           // ... compiled for AVX-512 when the CPU has F/VL/BW/DQ (same arithmetic)
};

struct RenderStats {
  std::uint64_t rays = 0;            // rays that hit the volume's box
  std::uint64_t samples = 0;         // trilinear samples (gradient taps not counted)
  std::uint64_t bricks_in_frame = 0; // bricks handed to the renderer
  std::uint64_t bricks_culled = 0;   // transparent under the TF ([min, max] test)
  std::uint64_t bricks_sampled = 0;  // bricks at least one ray sampled
  std::uint64_t cells_empty = 0;     // macro-cells skipped as transparent (visible bricks only)
  std::uint64_t cells_total = 0;     // macro-cells of the visible bricks
  std::uint64_t cell_ranges_built = 0;  // bricks whose cell flags were computed this frame
  double setup_ms = 0;               // frame index and tables
  double raycast_ms = 0;
  double total_ms = 0;
};

// {"render": {...}, "load": {...}} with the loader's figures when given (paper 1 Figs. 4-5).
nlohmann::json stats_json(const RenderStats& stats, const lod::LoadStats* load = nullptr);

// One frame's data: the resident bricks plus what places them in world space.
struct FrameInput {
  const lod::FrameBricks* bricks = nullptr;
  const ta::OctreeGeometry* geometry = nullptr;
  Spacing spacing;
  double value_min = 0, value_max = 1;  // the file's value range: TF normalisation
  // Optional: brick [min, max] from the file's index (cheaper than scanning samples). Absent
  // bricks (or no index) are scanned.
  const store::ContainerReader* index = nullptr;
};

// An in-memory volume prepared for repeated rendering (an orbit over a plain volume file): its
// samples as floats and their value range are worked out once, its empty-space cells once per
// ray caster that renders it. It reads the volume's samples in place when they are float, so
// the volume must outlive it and stay unchanged while it is in use.
class PreparedVolume {
 public:
  // [value_min, value_max] normalises values for the transfer function.
  PreparedVolume(const Volume& volume, double value_min, double value_max);
  // ... over the volume's own sample range. Throws Error when the volume is empty.
  explicit PreparedVolume(const Volume& volume);
  ~PreparedVolume();
  PreparedVolume(PreparedVolume&&) noexcept;
  PreparedVolume& operator=(PreparedVolume&&) noexcept;

 private:
  friend class RayCaster;
  std::unique_ptr<detail::FrameIndex> index_;  // one block: the volume
  double value_min_ = 0, value_max_ = 1;
  // Empty-space cells for ray caster flags_owner_: a caster's TF and options never change, nor
  // does this value range, so the caster's id is the whole key.
  std::shared_ptr<const detail::CellFlags> flags_;
  std::uint64_t flags_owner_ = 0;  // RayCaster::id_
};

class RayCaster {
 public:
  explicit RayCaster(TransferFunction tf, RenderOptions options = {});
  ~RayCaster();
  RayCaster(RayCaster&&) noexcept;
  RayCaster& operator=(RayCaster&&) noexcept;

  const TransferFunction& transfer_function() const { return tf_; }
  const RenderOptions& options() const { return options_; }

  // Renders the bricks of `frame`. Throws Error when a brick's key lies outside the geometry
  // or its samples are not B^3 floats. Not reentrant (classification tables are cached per
  // level); use one RayCaster per concurrent render.
  Image render(const Camera& camera, const FrameInput& frame, RenderStats* stats = nullptr);
  // Renders an in-memory volume as a single block (no bricks): the reference image bricked
  // renders are compared with. A one-off PreparedVolume; keep one to render many frames.
  Image render(const Camera& camera, const Volume& volume, double value_min, double value_max,
               RenderStats* stats = nullptr);
  Image render(const Camera& camera, PreparedVolume& volume, RenderStats* stats = nullptr);


 private:
  // The frame's common tail: level tables, ray casting, timings (from t0) into `stats`.
  Image cast(const Camera& camera, const detail::FrameIndex& index, const ValueMapping& mapping,
             SteadyClock::time_point t0, RenderStats& local, RenderStats* stats);

  TransferFunction tf_;
  RenderOptions options_;
  std::vector<std::unique_ptr<detail::LevelTables>> tables_;  // by level, built on first use
  std::unique_ptr<detail::CellFlagCache> cell_flags_;  // per brick, while the brick lives
  std::unique_ptr<const detail::Transparency> transparency_;  // of tf_, which never changes
  std::uint64_t id_;  // tells PreparedVolume whose empty-space cells it holds
};

// Every brick of `level` decoded at rank `rank` (clamped to the file's rank), in parallel;
// bricks whose histogram misses `visible_mask` (TransferFunction::visible_bins) are left out,
// constant bricks carry only their value. For rendering without the lod module.
lod::FrameBricks level_bricks(const ta::TaVolume& volume, int level, int rank,
                              std::uint64_t visible_mask = ~std::uint64_t(0));
// Cuts level 0 of an in-memory volume into bricks of `geometry` (edge-clamped overlap, as the
// compressor stores them), converted to float: uncompressed bricks for comparisons.
lod::FrameBricks bricks_from_volume(const Volume& volume, const ta::OctreeGeometry& geometry);

}  // namespace strata::render
