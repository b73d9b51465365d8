#pragma once
// Per-ray state and brick traversal of the ray caster. The march over one block's lattice
// points lives in march.cpp (scalar) and march8.cpp (8-lane, with its target attributes); the
// traversal here walks a ray through the frame index and calls it through MarchFns, and run()
// casts every ray of a frame in tiles and composites over the background. The tiles, the
// clipping to the volume's box and the box exits are the ones the label ray caster uses too
// (traversal.hpp).
#include <array>
#include <cstdint>
#include <vector>

#include "render/frame_index.hpp"
#include "render/ray_sampling.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/transfer_function.hpp"

namespace strata::render::detail {

// ---- Per-ray state --------------------------------------------------------------------------

struct RayContext {
  std::array<double, 3> origin, dir;
  std::array<float, 3> light;  // unit vector towards the light (the eye: a headlight)
};

struct RayState {
  Rgbaf acc;                   // premultiplied, front to back
  bool has_prev = false;       // a sample exists behind the current position
  bool open = false;           // the last region marched was a block (a closing segment is due)
  const Block* last = nullptr;
  int prev_level = 0;
  std::int64_t prev_k = 0;     // lattice index of the previous sample (at prev_level)
  double prev_t = 0;           // parameter of the previous sample (before the first: the volume entry)
  float prev_x = 0;            // normalised value of the previous sample
  std::uint64_t samples = 0;
  std::uint8_t* touched = nullptr;  // per-thread flags: blocks this thread sampled
};

struct LevelParams {
  double h = 1;                // world step of the level
  Classifier classify;
  float shade_threshold = 0;   // kShadeThreshold corrected to the level's step (shading.hpp)
};

struct MarchParams {
  bool simd;    // 8-lane path for pre-integrated grid blocks (march8)
  bool avx512;  // ... in its AVX-512 build
  const LevelParams* levels;
  const std::uint16_t* next_visible;
  float value_lo, value_scale;  // normalisation
  ShadingParams light;
  float termination;
};

// The march of one block (march.cpp): its lattice points (lattice) and the partial
// segment to the volume exit (tail).
struct MarchFns {
  bool (*lattice)(const Block&, std::int64_t, std::int64_t, const RayContext&, const MarchParams&, RayState&, bool);
  void (*tail)(const Block&, double, const RayContext&, const MarchParams&, RayState&);
};

// The march of block b's kind (march.cpp).
MarchFns march_function(const Block& b, bool preint, bool shade);

struct RenderJob {
  const Transparency& transparency;  // of the frame's transfer function
  const Camera& camera;
  const FrameIndex& index;
  const RenderOptions& options;
  const std::vector<LevelParams>& levels;
  float value_lo, value_scale;
};

// Casts and composites every ray of the frame (tiles in parallel); fills the rays, samples and
// bricks_sampled fields of `stats`.
Image run(const RenderJob& job, RenderStats& stats);

}  // namespace strata::render::detail
