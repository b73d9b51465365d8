#pragma once
// The three kinds of RenderSource (render_source.hpp): a TA file (ta_source.cpp), a plain volume
// file (plain_source.cpp) and a label file (label_source.cpp), and what they share
// (render_source.cpp): the ray caster slot, the default camera's framing, the frame's options.
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/render_source.hpp"
#include "strata/lod/brick_provider.hpp"
#include "strata/lod/selection.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/label_color_map.hpp"
#include "strata/render/label_raycaster.hpp"
#include "strata/render/label_scene.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/render_session.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::render {

// The ray caster of the latest transfer function and options: a RayCaster's TF and options are
// fixed, and its per-brick empty-space flags pay off only while they stay the same.
class CasterSlot {
 public:
  RayCaster& get(const TransferFunction& tf, const RenderOptions& options);

 private:
  std::string key_;
  std::unique_ptr<RayCaster> caster_;
};

// What the default camera frames (CameraSpec::frame_radius): the sphere about the volume's
// centre that holds every box added, in world units; the boxes are where the volume shows
// something under its default look (the "ct" preset, or every label but 0).
// The radius is rounded up to a sixteenth of the bounding sphere's, so a plain volume and its
// compressed copy, whose coarse values differ a little, frame alike.
struct FrameSphere {
  static constexpr std::int64_t kWidest = 64;  // cells per axis of the level looked at
  static constexpr double kSteps = 16;
  Vec3 centre;
  double bounding = 0, radius = 0;
  FrameSphere(const Extent& dims, const Spacing& spacing);
  void add_box(const Vec3& lo, const Vec3& hi);  // its farthest corner
  // The level-0 voxels of cell (x, y, z) of level `level` (clipped to the volume).
  void add_cell(const Extent& dims0, const Spacing& s, int level, std::int64_t x, std::int64_t y, std::int64_t z);
  double rounded() const;  // 0 when nothing was added
};

// The coarsest level (halving as the octree does) at most FrameSphere::kWidest wide.
int frame_level(Extent dims);

// The cells of `coarse` (level `level` of a volume of `dims0`) that the default transfer
// function shows, over the value range [lo, hi]: FrameSphere's radius for scalar values.
double visible_cells_radius(const Volume& coarse, int level, const Extent& dims0, const Spacing& s, double lo, double hi);

// The ray caster options of a frame.
RenderOptions render_options(const FrameSettings& settings, const std::array<float, 4>& background);
// The "ct" preset unless the frame names a transfer function.
const TransferFunction& frame_tf(const FrameSettings& settings);

// A slice of `box` (a slice's box at its level) with every value zero.
template <class T>
Slice<T> empty_slice(const Box& box, SliceAxis axis) {
  Slice<T> out;
  std::tie(out.width, out.height) = slice_size(box, axis);
  out.values.resize(std::size_t(out.width) * std::size_t(out.height));
  return out;
}

// A TA file: LOD cut -> brick provider -> ray caster. Slices and values are read through the
// same provider, so they share its caches with the frames.
class TaSource final : public RenderSource {
 public:
  // Throws ParameterError("SessionOptions::cache_bytes") when the cache cannot hold one brick.
  TaSource(std::filesystem::path path, std::unique_ptr<store::ContainerReader> input, const SessionOptions& options);

  DatasetKind kind() const override { return DatasetKind::scalar; }
  Spacing spacing() const override { return volume_.source_info().spacing; }
  Geometry geometry() const override { return volume_.source_info().geometry; }
  int level_count() const override { return volume_.geometry().level_count(); }
  Extent level_dims(int level) const override { return volume_.geometry().level(level).dims; }
  int stored_rank() const override { return volume_.rank(); }
  std::pair<double, double> value_range() const override { return {volume_.value_min(), volume_.value_max()}; }
  DType dtype() const override { return volume_.source_info().dtype; }
  std::vector<std::uint64_t> histogram() const override;
  std::vector<int> feature_scale_ladder() const override { return volume_.feature_scale_ladder(); }
  double frame_radius() const override;
  Image frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
              nlohmann::json& stats) override;
  Slice<float> value_slice(const SliceSpec& spec) override;
  double value_at(const Extent& voxel, int rank) override;

 private:
  // Calls f(x, y, z, value) for every voxel of `box` (level `level` coordinates) at rank K,
  // read through the provider (exact: waits for every brick the box meets).
  template <class F>
  void visit_box(int level, const Box& box, int rank, F&& f);
  // Queues the bricks of the brick layers before and after the slice's (along its axis) on
  // the loader without waiting: a viewer scrolls through slices, and the next layer is then
  // decoded in the background instead of while the user waits.
  void prefetch_slice_neighbours(const SliceSpec& spec);
  // Calls f(cut brick) for every brick of `level` whose core meets `box` (level coordinates).
  template <class F>
  void for_each_brick_in(int level, const Box& box, F&& f) const;

  ta::TaVolume volume_;
  lod::BrickProvider provider_;
  CasterSlot casters_;
  lod::SelectionOptions selection_;
};

// A plain volume file (raw, NRRD, NIfTI, TIFF): loaded whole as floats and ray cast as one
// block, the uncompressed reference a compressed file's rendering can be compared with. Its
// value range and empty-space cells are worked out once, not per frame.
class PlainSource final : public RenderSource {
 public:
  PlainSource(std::filesystem::path path, std::optional<std::int64_t> volume);

  DatasetKind kind() const override { return DatasetKind::plain; }
  Spacing spacing() const override { return volume_.spacing(); }
  Geometry geometry() const override { return volume_.info().geometry; }
  int level_count() const override { return 1; }
  Extent level_dims(int) const override { return volume_.dims(); }
  std::pair<double, double> value_range() const override { return range_; }
  DType dtype() const override { return source_dtype_; }
  std::vector<std::uint64_t> histogram() const override;
  double frame_radius() const override;  // voxels the "ct" preset shows
  Image frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
              nlohmann::json& stats) override;
  Slice<float> value_slice(const SliceSpec& spec) override;
  double value_at(const Extent& voxel, int rank) override;

 private:
  DType source_dtype_ = DType::f32;
  Volume volume_;  // f32
  std::pair<double, double> range_;  // of the samples
  CasterSlot casters_;
  PreparedVolume prepared_;
};

// A label file: palette through the Mixture Graph, then the label ray caster. The scene keeps
// decoded node ids, so later frames only march (and recolour when asked).
class LabelSource final : public RenderSource {
 public:
  LabelSource(std::filesystem::path path, std::unique_ptr<store::ContainerReader> input);

  DatasetKind kind() const override { return DatasetKind::labels; }
  Spacing spacing() const override { return labels_.spacing(); }
  Geometry geometry() const override { return labels_.geometry(); }
  int level_count() const override { return labels_.level_count(); }
  Extent level_dims(int level) const override { return labels_.level_dims(level); }
  std::pair<double, double> value_range() const override;
  DType dtype() const override { return labels_.label_map().dtype(); }
  std::size_t label_count() const override { return labels_.label_map().size(); }
  bool has_label(std::int64_t label) const override { return labels_.label_map().id_of(label).has_value(); }
  bool has_normals() const override { return normals_ != nullptr; }
  const mixture::LabelNames& label_names() const override { return names_; }
  double frame_radius() const override;
  Image frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
              nlohmann::json& stats) override;
  Slice<float> value_slice(const SliceSpec& spec) override;
  double value_at(const Extent& voxel, int rank) override;
  Slice<std::int64_t> label_slice(const SliceSpec& spec) override;
  Slice<float> label_fraction_slice(const SliceSpec& spec, std::int64_t label) override;
  Image palette_slice(const SliceSpec& spec) override;
  std::int64_t label_at(const Extent& voxel) const override;
  bool label_visible(std::int64_t label) const override { return colors_.color_of(label).a > 0; }
  double set_label_colors(LabelColorMap colors) override;
  const mixture::EncodedLabels& labels() const override { return labels_; }

 private:
  // Node ids of a slice at its level, in slice order (decode_box's x-fastest order is the
  // slice order), and the slice's width and height.
  std::vector<std::uint32_t> slice_nodes(const SliceSpec& spec, std::pair<int, int>& size) const;

  mixture::EncodedLabels labels_;
  render::LabelScene scene_;
  std::unique_ptr<LabelShading> normals_;  // the file's normals graph, when it has one
  mixture::LabelNames names_;              // metadata.label_names, checked on opening
  LabelColorMap colors_;
  // Per node, for slices: the dominant source (built on first use) and the colour of the
  // visible labels made opaque, so a slice shows coverage, not the 3D opacity.
  std::vector<std::uint32_t> dominant_;
  std::vector<float> slice_palette_;
  std::optional<std::int64_t> fraction_label_;  // the label `fractions_` holds
  std::vector<float> fractions_;
};

}  // namespace strata::render
