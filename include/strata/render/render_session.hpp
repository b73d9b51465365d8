#pragma once
/// @file
/// @brief One volume file opened for viewing: frames, slices, voxel values, label colours and
/// its description. What `strata render`, `strata demo` and `strata serve` share.
///
/// TA files go through the LOD cut, the brick provider (cache + loader) and the ray caster
/// (paper 1, §3/§6); label files through the Mixture Graph palette (paper 4, §4); plain volume
/// files (raw, NRRD, NIfTI, TIFF) are loaded whole as floats and ray cast as one block (the
/// uncompressed reference). Slices and voxel values of TA files are read through the same brick
/// provider, so they share its caches with the frames (a rank change re-reconstructs from the
/// cached models without reading the file).
///
/// Thread safety: one call at a time (the caches, the ray caster and the label scene are
/// per-session state); `labels()` may be used concurrently for read-only queries.
/// The header stays free of Eigen (the server includes it beside httplib).
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string_view>
#include <utility>

#include <nlohmann/json.hpp>

#include "strata/core/extent.hpp"
#include "strata/core/volume.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"
#include "strata/render/label_color_map.hpp"
#include "strata/render/pick.hpp"
#include "strata/render/slices.hpp"
#include "strata/render/transfer_function.hpp"

namespace strata::mixture {
class EncodedLabels;
}

namespace strata::render {

class RenderSource;  // src/render/render_source.hpp

/// @brief What a file holds: a TA octree ("scalar"), a Mixture Graph ("labels") or a plain
/// volume held in memory ("plain").
enum class DatasetKind : std::uint8_t { scalar, labels, plain };
/// @brief "scalar", "labels" or "plain".
std::string_view dataset_kind_name(DatasetKind kind);

/// @brief How complete a frame must be.
enum class FrameQuality : std::uint8_t {
  exact,        ///< waits for every brick of the cut; one ray per pixel
  progressive,  ///< draws what is resident (stand-ins for misses, the loader catches up); one ray per pixel
  interactive,  ///< progressive, with rays on a coarser image grid (so a coarser LOD cut) to hold
                ///< SessionOptions::target_fps, resized to the requested size
};

/// @brief Fixed for the session's lifetime.
struct SessionOptions {
  std::uint64_t cache_bytes = 1ull << 30;          ///< reconstructed bricks; also the cut's memory budget
  std::uint64_t model_cache_bytes = 256ull << 20;  ///< dequantized models (the rank slider's source)
  std::int64_t max_bricks = 8192;                  ///< bricks in a LOD cut
  int loader_threads = 0;                          ///< 0 = lod::default_loader_threads()
  std::array<float, 4> background{0, 0, 0, 1};     ///< straight RGBA in [0, 1]
  double target_fps = 0;                           ///< interactive frames' rate; 0 = full resolution
  double min_interactive_scale = 1;                ///< interactive frames cast at most 1/this rays per edge
  /// Which volume of a file that holds several (a 4-D NIfTI or NRRD, a multi-channel TIFF, a
  /// .strata volume set); such a file is refused without it. Files of one volume take 0 or none.
  std::optional<std::int64_t> volume;
};

/// @brief Label files: which light a shaded frame uses (label_raycaster.hpp, LabelLighting).
enum class LabelLightingChoice {
  automatic,  ///< the normals graph when the file has one, else opacity gradients
  gradient,
  gradient_occlusion,  ///< opacity gradients with local ambient occlusion
  normals,    ///< refused for a file without a normals graph
};

/// @brief Everything that may change from one frame to the next.
struct FrameSettings {
  CameraSpec camera;
  std::shared_ptr<const TransferFunction> tf;  ///< scalar and plain files; null = the "ct" preset
  int rank = 0;                                ///< TA files: reconstruction rank K (1..stored); 0 = the stored rank
  double lod = 1.0;                            ///< TA files: pixels per voxel before a brick is refined
  /// ta-global files: ε_target of paper 2's Alg. 2, a normalized RMSE (RMSE / value range) that
  /// picks each brick's rank and bounds refinement (lod/selection.hpp); 0 = off.
  double feature_scale = 0;
  double lod_bias = 0.0;                       ///< label files: added to the per-sample mip level
  LabelLightingChoice label_lighting = LabelLightingChoice::automatic;  ///< label files, with shading
  double step = 0.5;                           ///< sample distance in voxels of the sampled level
  bool shading = true;
  /// Scalar and plain files: per-pixel lattice offsets (RenderOptions::jitter), and the
  /// refinement pass at rest that picks their pattern (RenderOptions::jitter_pass). The mean of
  /// passes 0..n-1 converges to the image without sampling noise.
  bool jitter = true;
  std::uint32_t pass = 0;
  FrameQuality quality = FrameQuality::exact;
};

/// @brief Throws ParameterError naming the field unless the camera passes validate(CameraSpec),
/// the step check_step (sampling_limits.hpp), lod is finite in (0, 64] pixels, lod_bias finite
/// in [-64, 64] levels, rank >= 0 and feature_scale finite in [0, 1]. RenderSession::frame
/// checks this first (and that a non-zero feature_scale meets a ta-global file).
void validate(const FrameSettings& settings);
/// @brief Throws ParameterError naming the field unless the cache budgets are positive,
/// max_bricks >= 1, loader_threads >= 0, target_fps finite in [0, 1e6], min_interactive_scale
/// finite in [1, 64] and the background components in [0, 1]. The RenderSession constructor
/// checks this first (and, for TA files, that cache_bytes holds at least one brick).
void validate(const SessionOptions& options);

class RenderSession {
 public:
  /// @brief Opens `input` (a .strata file of either codec, or any volume file io reads): the
  /// first opener of the table in src/render/render_source.hpp that accepts the file makes its
  /// source, once. Throws Error (FormatError naming the file) when it cannot be read, and
  /// ParameterError naming the SessionOptions field when validate(options) does.
  RenderSession(const std::filesystem::path& input, const SessionOptions& options = {});
  ~RenderSession();
  RenderSession(const RenderSession&) = delete;
  RenderSession& operator=(const RenderSession&) = delete;

  /// @brief What the file holds (the kind of source its opener made).
  DatasetKind kind() const;
  /// @brief Voxels of level 0.
  Extent dims() const;
  /// @brief World size of a level-0 voxel.
  Spacing spacing() const;
  /// @brief Octree levels (TA), mip levels (labels), 1 (plain).
  int level_count() const;
  /// @brief Voxels of `level`; throws ParameterError("level") outside 0..level_count()-1.
  Extent level_dims(int level) const;
  /// @brief The stored rank (TA files; the rank slider's maximum); 0 otherwise.
  int stored_rank() const;
  /// @brief The sample range (scalar, plain) or the smallest and largest label (labels).
  std::pair<double, double> value_range() const;
  /// @brief The transfer-function preset this data opens with (render::default_preset of
  /// display_defaults.hpp: from the file's name, value range and world space): what the viewer
  /// and `strata render --tf auto` show first.
  std::string default_preset() const;
  /// @brief Whether `label` occurs in a label file (false for other kinds).
  bool has_label(std::int64_t label) const;
  /// @brief Whether a label file carries a normals graph (`labels encode --normals`).
  bool has_normals() const;
  /// @brief Whether a TA file carries a feature-scale table (ta-global), so frames may set
  /// FrameSettings::feature_scale.
  bool has_feature_scale() const;
  /// @brief {"name", "kind", "dims", "spacing", "dtype", "levels", "rank", "value_range",
  /// "histogram", "label_count"} as docs/viewer.md describes `GET /api/datasets`.
  nlohmann::json describe() const;

  /// @brief One frame. `stats` receives its figures (selection, load, render, frame_ms, cpu_s,
  /// image_scale, rank). Throws ParameterError when validate(settings) does, and
  /// ParameterError("rank") for a rank above the stored one (ta::reconstruction_rank).
  Image frame(const FrameSettings& settings, nlohmann::json& stats);

  /// @brief Scalar and plain files: the values of a slice at its level and rank.
  /// Throws ParameterError("SliceSpec::level") / ("SliceSpec::index") when out of range, Error
  /// for label files.
  Slice<float> value_slice(const SliceSpec& spec);
  /// @brief Label files: the label of every voxel of a slice (level 0: the labels themselves;
  /// coarser: the dominant label). Throws as value_slice, Error for other kinds.
  Slice<std::int64_t> label_slice(const SliceSpec& spec);
  /// @brief Label files: the fraction of `label` in every voxel of a slice. Also throws Error
  /// when the label does not occur.
  Slice<float> label_fraction_slice(const SliceSpec& spec, std::int64_t label);
  /// @brief Label files: the slice in the current label colours (set_label_colors), each voxel
  /// the coverage-weighted mean colour of its visible labels with their coverage as (straight)
  /// alpha; transparent where no visible label is.
  Image palette_slice(const SliceSpec& spec);

  /// @brief Scalar and plain files: the value at a level-0 voxel, at rank `rank` (0 = stored).
  /// Throws ParameterError("voxel") outside the volume, Error for label files.
  double value_at(const Extent& voxel, int rank = 0);
  /// @brief Label files: the label at a level-0 voxel. Throws as value_at.
  std::int64_t label_at(const Extent& voxel) const;

  /// @brief What pixel (px, py) of the frame `camera` describes shows (Camera::ray; the camera
  /// resolved as frame() resolves it): the first level-0 voxel along the pixel's ray that is
  /// solid in the picture. Label files: a voxel whose label is visible in the current colours
  /// (set_label_colors; "only selected" and hidden labels count as the frames show them).
  /// Scalar and plain files: the voxel where the opacity accumulated under `tf` (per voxel
  /// crossed, corrected for the length inside it; values at rank `rank`) reaches kPickOpacity.
  /// Nothing when the ray meets no such voxel. Throws ParameterError("rank") as value_at.
  std::optional<Pick> pick(const CameraSpec& camera, double px, double py, const TransferFunction& tf, int rank = 0);

  /// @brief Label files: new label colours for frames and palette slices, propagated through
  /// the Mixture Graph now; returns the milliseconds that took. Error for other kinds.
  double set_label_colors(LabelColorMap colors);
  /// @brief Label files: the encoded volume (box queries may run on it concurrently with
  /// anything this session does). Error for other kinds.
  const mixture::EncodedLabels& labels() const;

 private:
  std::filesystem::path path_;
  SessionOptions options_;
  // What the file holds, behind one interface (src/render/render_source.hpp): the opener that
  // accepted the file chose the implementation; nothing here tells kinds apart.
  std::unique_ptr<RenderSource> source_;
  double image_scale_ = 1;  // image edge divisor of interactive frames, adapted per frame
  double frame_radius_ = 0;  // the content's sphere about the volume centre (CameraSpec::frame_radius)
  bool calibrated_ = false;
  void adapt_image_scale(double used_scale, double frame_ms);
  void check_level(int level) const;
};

/// @brief Mean frame time, frames/s, CPU seconds per frame and the decode share of frame time,
/// over all frames and (key "after_first") without the first frame, which loads the whole cut.
nlohmann::json frame_summary(const nlohmann::json& frames);

}  // namespace strata::render
