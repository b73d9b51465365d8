#pragma once
// Rendering a file frame by frame, shared by `strata render` and `strata demo`. TA files go
// through the LOD cut, the brick provider (cache + loader) and the ray caster (paper 1,
// §3/§6); label files through the Mixture Graph palette (paper 4, §4); plain volume files are
// loaded whole and ray cast as one block (the uncompressed reference).
#include <array>
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "strata/core/extent.hpp"
#include "strata/core/volume.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"

namespace strata::cli {

struct RenderSettings {
  std::string tf = "ct";          // TA files: preset or JSON file
  std::string colors;             // label files: JSON colour map ("" = hash colours)
  int rank = 0;                   // reconstruction rank K; 0 = the stored rank
  double lod = 1.0;               // pixels per voxel before a brick is refined
  double lod_bias = 0.0;          // label files: added to the per-sample mip level
  double step = 0.5;              // sample distance in voxels of the sampled level
  bool shading = true;
  std::array<float, 4> background{0, 0, 0, 1};
  std::uint64_t cache_bytes = 1ull << 30;
  std::int64_t max_bricks = 8192;
  // Interactive frames (not exact): cast fewer rays to hold this frame rate, as interactive
  // renderers do while the camera moves; 0 = always full resolution.
  double target_fps = 0;
};

class RenderSession {
 public:
  RenderSession(const std::filesystem::path& input, const RenderSettings& settings);
  ~RenderSession();

  Extent dims() const;
  Spacing spacing() const;
  // One frame; `exact` waits for every brick of the cut (TA files) and always casts one ray
  // per pixel. Otherwise, with a target frame rate, rays are cast on a coarser image grid
  // (its pixels are larger, so the LOD cut is coarser too) and the result is resized.
  // `stats` receives the frame's figures (selection, load, render, frame_ms, cpu_s, image_scale).
  render::Image frame(const render::CameraSpec& camera, bool exact, nlohmann::json& stats);
  // Changes the reconstruction rank for later frames (the rank slider; TA files).
  void set_rank(int rank);

 private:
  struct Scalar;
  struct Labels;
  struct Plain;
  std::unique_ptr<Plain> plain_;
  std::unique_ptr<Scalar> scalar_;
  std::unique_ptr<Labels> labels_;
  double target_fps_ = 0;
  double image_scale_ = 1;  // image edge divisor of interactive frames, adapted per frame
  bool calibrated_ = false;
  void adapt_image_scale(double used_scale, double frame_ms);
};

// Mean frame time, frames/s, CPU seconds per frame and the decode share of frame time, over
// all frames and (key "after_first") without the first frame, which loads the whole cut.
nlohmann::json frame_summary(const nlohmann::json& frames);

}  // namespace strata::cli
