#pragma once
// What RenderSession reads a dataset through: one interface (RenderSource) with one
// implementation per kind of file (render_source_kinds.hpp: a TA file, a plain volume, a label
// file), and the table of openers that picks the implementation once, when the file is opened.
// A new kind of source (a remote file, a new codec) is a RenderSource and one row of the table.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/core/extent.hpp"
#include "strata/core/volume.hpp"
#include "strata/mixture/label_names.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"
#include "strata/render/label_color_map.hpp"
#include "strata/render/render_session.hpp"
#include "strata/render/slices.hpp"

namespace strata::store {
class ContainerReader;
}

namespace strata::render {

// One dataset opened for viewing. RenderSession checks levels and frame settings and sizes the
// camera; the source answers everything that depends on what the file holds. Operations a kind
// does not support throw Error naming the file: the label operations' defaults below do, for
// every kind but labels; a label file's value operations do. A supported operation checks its
// arguments after its kind (so asking a scalar file for a label slice at a bad level names the
// kind, not the level), as RenderSession documents. One call at a time, as RenderSession; only
// labels() may be read concurrently.
class RenderSource {
 public:
  virtual ~RenderSource();
  RenderSource(const RenderSource&) = delete;
  RenderSource& operator=(const RenderSource&) = delete;

  // The file as the session was opened with it (the name in error messages).
  const std::filesystem::path& path() const { return path_; }

  virtual DatasetKind kind() const = 0;
  virtual Spacing spacing() const = 0;
  // Where level 0 lies in world space (origin, axis directions, space, unit): the source file's.
  virtual Geometry geometry() const = 0;
  virtual int level_count() const = 0;
  // Voxels of `level`, 0 <= level < level_count() (RenderSession checks).
  virtual Extent level_dims(int level) const = 0;
  // The stored rank (TA files); 0 for the others.
  virtual int stored_rank() const { return 0; }
  // The sample range (scalar, plain) or the smallest and largest label (labels).
  virtual std::pair<double, double> value_range() const = 0;
  // The source's sample type: a plain file's on disk, a TA file's original, the label values'.
  virtual DType dtype() const = 0;
  // Counts of sample values in kValueHistogramBins bins over value_range() (display_defaults.hpp):
  // describe()'s 64-bin "histogram" and the slice window come from it; none for labels.
  virtual std::vector<std::uint64_t> histogram() const { return {}; }
  // A ta-global file's feature-scale ladder (FrameSettings::feature_scale); empty otherwise.
  virtual std::vector<int> feature_scale_ladder() const { return {}; }
  virtual std::size_t label_count() const { return 0; }
  virtual bool has_label(std::int64_t) const { return false; }
  virtual bool has_normals() const { return false; }
  // Label files: the segment names the file stores (metadata.label_names); none otherwise.
  virtual const mixture::LabelNames& label_names() const {
    static const mixture::LabelNames none;
    return none;
  }
  // The radius the default camera frames (CameraSpec::frame_radius); asked once, on opening.
  virtual double frame_radius() const = 0;

  // One frame through `camera` (already at the size the frame's quality casts); `stats`
  // receives the frame's figures (RenderSession::frame adds its own).
  virtual Image frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
                      nlohmann::json& stats) = 0;

  // Sample values (scalar and plain files; label files throw Error).
  virtual Slice<float> value_slice(const SliceSpec& spec) = 0;
  virtual double value_at(const Extent& voxel, int rank) = 0;

  // Labels (label files; the defaults throw Error: "not a label volume").
  virtual Slice<std::int64_t> label_slice(const SliceSpec& spec);
  virtual Slice<float> label_fraction_slice(const SliceSpec& spec, std::int64_t label);
  virtual Image palette_slice(const SliceSpec& spec);
  virtual std::int64_t label_at(const Extent& voxel) const;
  // Label files: whether `label` shows in the current colours (set_label_colors).
  virtual bool label_visible(std::int64_t) const { return false; }
  virtual double set_label_colors(LabelColorMap colors);
  virtual const mixture::EncodedLabels& labels() const;

 protected:
  explicit RenderSource(std::filesystem::path path);
  // ParameterError("SliceSpec::level") / ("SliceSpec::index") unless the slice is in the volume.
  void check_slice(const SliceSpec& spec) const;
  // ParameterError("voxel") unless the level-0 voxel is in the volume.
  void check_voxel(const Extent& voxel) const;
  // The box of a checked slice at its level.
  Box level_slice_box(const SliceSpec& spec) const;
  // Error naming the file and its kind, for label operations on other kinds.
  [[noreturn]] void not_labels() const;

 private:
  std::filesystem::path path_;
};

// A file being opened, as the openers see it: its path, the volume asked for, and for .strata
// files the container, opened on first use (once, whichever opener asks) and handed to the
// source that takes it.
class SourceFile {
 public:
  SourceFile(std::filesystem::path path, std::optional<std::int64_t> volume);
  ~SourceFile();
  const std::filesystem::path& path() const { return path_; }
  std::optional<std::int64_t> volume() const { return volume_; }
  // Whether the file is a .strata container (store::is_strata_file), asked once.
  bool is_container();
  // The container's codec (its metadata's "codec"; "" without one): opens the container (the
  // volume asked for, store::open_volume) unless open already. Only for containers.
  std::string codec();
  // The open container, for the source to keep; opens it first when no one asked yet.
  std::unique_ptr<store::ContainerReader> take_container();

 private:
  store::ContainerReader& container();
  std::filesystem::path path_;
  std::optional<std::int64_t> volume_;
  std::optional<bool> is_container_;
  std::unique_ptr<store::ContainerReader> container_;
};

// One row of the openers' table: the first row whose accepts() holds opens the file.
struct SourceOpener {
  std::string_view name;  // the kind it opens, as dataset_kind_name spells it
  bool (*accepts)(SourceFile& file);
  std::unique_ptr<RenderSource> (*open)(SourceFile& file, const SessionOptions& options);
};

// The openers in the order they are asked: plain volume files, label files (the Mixture Graph
// codec), and every other .strata file as a TA octree.
std::span<const SourceOpener> source_openers();

// The source of `path`, opened by the first opener of source_openers() that accepts it (the
// volume SessionOptions::volume names). Throws what opening the file throws (FormatError naming
// the file, ParameterError naming a SessionOptions field), and Error when no opener accepts it.
std::unique_ptr<RenderSource> open_render_source(const std::filesystem::path& path, const SessionOptions& options);

}  // namespace strata::render
