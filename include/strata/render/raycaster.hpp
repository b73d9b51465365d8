#pragma once
/// @file
/// @brief CPU ray caster over reconstructed bricks with pre-integrated 1D transfer functions.
///
/// Implements the renderer of paper 1 §3 (ray casting of decoded bricks). Each sample reads a
/// single brick (trilinear inside its 2-voxel overlap), each level has its own sample step,
/// level changes are composited without gaps but without the interblock interpolation of §6.3,
/// and transparent bricks and macro-cells are skipped. When active_isa() allows AVX2 or AVX-512
/// (strata/core/isa.hpp) the march inside a brick takes 8 lattice points at a time.
/// Design notes: docs/rendering.md; measurements: docs/benchmarks.md#rendering-cpu-ray-caster-strata-render
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
struct LevelTables;  // per-level classification tables (src/render/level_tables.hpp)
struct CellFlags;
struct FrameIndex;
struct Transparency;
}

/// @brief Blinn-Phong coefficients of the headlight shading.
struct ShadingParams {
  float ambient = 0.3f, diffuse = 0.7f, specular = 0.25f;
  int shininess = 24;  // Blinn-Phong exponent (integer: evaluated by repeated squaring)
};

/// @brief Sampling, classification and scheduling options of a RayCaster (checked by its
/// constructor).
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
  // Each pixel's sample lattice starts at its own fraction of a step (interleaved gradient
  // noise): a lattice shared by neighbouring rays turns the step's error into coherent
  // "wood-grain" rings on zoomed surfaces; offsets spread it into fine noise instead.
  bool jitter = true;
  // Which offset pattern: pass k adds k times the golden ratio to every pixel's offset, so the
  // mean of passes 0..n-1 samples each ray at n evenly spread phases (refinement at rest).
  std::uint32_t jitter_pass = 0;
};

/// @brief Counters and timings of one frame, written by RayCaster::render.
struct RenderStats {
  std::uint64_t rays = 0;            // rays that hit the volume's box
  std::uint64_t samples = 0;         // trilinear samples (gradient taps not counted)
  std::uint64_t bricks_in_frame = 0; // bricks handed to the renderer
  std::uint64_t bricks_culled = 0;   // transparent under the TF ([min, max] test)
  std::uint64_t bricks_sampled = 0;  // bricks at least one ray sampled
  std::uint64_t cells_empty = 0;     // macro-cells skipped as transparent (visible bricks only)
  std::uint64_t cells_total = 0;     // macro-cells of the visible bricks
  std::uint64_t cell_ranges_built = 0;  // bricks whose cell flags were computed this frame
  double setup_ms = 0;               // frame index, empty-space flags and classification tables
  double raycast_ms = 0;
  double total_ms = 0;
};

/// @brief A frame's figures as JSON (paper 1 Figs. 4-5).
/// Returns {"render": {...}} with every field of `stats`, plus {"load": {...}} with the loader's
/// figures when `load` is not null. Pure function: safe to call from any thread.
nlohmann::json stats_json(const RenderStats& stats, const lod::LoadStats* load = nullptr);

/// @brief One frame's data: the resident bricks plus what places them in world space.
/// `bricks` and `geometry` are required; everything pointed to must stay valid and unchanged
/// during RayCaster::render.
struct FrameInput {
  const lod::FrameBricks* bricks = nullptr;
  const ta::OctreeGeometry* geometry = nullptr;
  Spacing spacing;
  double value_min = 0, value_max = 1;  // the file's value range: TF normalisation
  // Optional: brick [min, max] from the file's index (cheaper than scanning samples). Absent
  // bricks (or no index) are scanned.
  const store::ContainerReader* index = nullptr;
};

/// @brief An in-memory volume prepared for repeated rendering (an orbit over a plain volume file).
///
/// Its samples as floats and their value range are worked out once, its empty-space cells once
/// per ray caster that renders it. Float samples are read in place, so the volume must outlive
/// this object and stay unchanged while it is in use; other sample types are converted to a
/// float copy it owns. Rendering updates it (brick culling, cached cells), so render one
/// PreparedVolume from one thread at a time. Move-only.
class PreparedVolume {
 public:
  /// @brief Prepares `volume`; [value_min, value_max] normalises values for the transfer function.
  /// Throws Error when the volume is empty, its spacing is not positive or an extent exceeds
  /// 2^31 - 1.
  PreparedVolume(const Volume& volume, double value_min, double value_max);
  /// @brief The same, normalised over the volume's own sample range. Throws as above.
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

/// @brief Renders frames of bricks, or in-memory volumes, under one transfer function and one
/// set of options, both fixed for the object's lifetime.
///
/// Thread safety: render() is not reentrant. It caches classification tables per level and
/// empty-space flags per brick inside the object, so use one RayCaster per concurrent render.
/// Each render runs its ray casting on `options.threads` OpenMP threads (0 = strata::thread_count()).
/// The flag cache refers to bricks weakly: it never keeps a brick's samples alive.
class RayCaster {
 public:
  /// @brief Throws Error unless step > 0, 2 <= table_size <= 4096, tile >= 1,
  /// termination_alpha lies in (0, 1] and every background component lies in [0, 1].
  explicit RayCaster(TransferFunction tf, RenderOptions options = {});
  ~RayCaster();
  RayCaster(RayCaster&&) noexcept;
  RayCaster& operator=(RayCaster&&) noexcept;

  /// @brief The transfer function and options fixed at construction.
  const TransferFunction& transfer_function() const { return tf_; }
  const RenderOptions& options() const { return options_; }
  /// @brief Picks the jitter pattern of later renders (RenderOptions::jitter_pass): the one
  /// option that changes from frame to frame without touching the caster's tables.
  void set_jitter_pass(std::uint32_t pass) { options_.jitter_pass = pass; }

  /// @brief Renders the bricks of `frame` into a camera.width() x camera.height() image.
  /// Writes the frame's figures to `*stats` when it is not null. Throws Error when
  /// frame.bricks or frame.geometry is null, the spacing is not positive, a brick's key lies
  /// outside the geometry or a non-constant brick does not hold B^3 samples.
  Image render(const Camera& camera, const FrameInput& frame, RenderStats* stats = nullptr);
  /// @brief Renders an in-memory volume as a single block (no bricks): the reference image
  /// bricked renders are compared with. Builds a one-off PreparedVolume (its time counts in
  /// setup_ms and total_ms) and throws as its constructor; keep one to render many frames.
  Image render(const Camera& camera, const Volume& volume, double value_min, double value_max,
               RenderStats* stats = nullptr);
  /// @brief Renders a prepared volume. Its empty-space cells (when cells are skipped) are
  /// computed on the first render by this caster and reused afterwards.
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

/// @brief Every brick of `level` decoded at rank `rank` (clamped to 1..the file's rank), for
/// rendering without the lod module.
/// Bricks whose histogram misses `visible_mask` (TransferFunction::visible_bins) are left out;
/// constant bricks carry only their value. Decodes on strata::thread_count() OpenMP threads.
/// Throws Error when `level` is not a level of the file; decoding errors (Error, FormatError)
/// propagate.
lod::FrameBricks level_bricks(const ta::TaVolume& volume, int level, int rank,
                              std::uint64_t visible_mask = ~std::uint64_t(0));
/// @brief Cuts level 0 of an in-memory volume into bricks of `geometry` (edge-clamped overlap,
/// as the compressor stores them), converted to float: uncompressed bricks for comparisons.
/// Throws Error when the volume's dims differ from the geometry's level 0.
lod::FrameBricks bricks_from_volume(const Volume& volume, const ta::OctreeGeometry& geometry);

}  // namespace strata::render
