#pragma once
// The three kinds of RenderSession (render_session.cpp: opening and frames; session_slices.cpp:
// slices, values and label colours).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

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

// A TA file: LOD cut -> brick provider -> ray caster.
struct RenderSession::Scalar {
  ta::TaVolume volume;
  lod::BrickProvider provider;
  CasterSlot casters;
  lod::SelectionOptions selection;

  Scalar(std::unique_ptr<store::ContainerReader> input, const SessionOptions& options);
  double frame_radius() const;
  Image frame(const Camera& camera, const FrameSettings& settings, const RenderOptions& options, nlohmann::json& stats);
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
  std::vector<std::uint64_t> histogram() const;
};

// A label file: palette through the Mixture Graph, then the label ray caster. The scene keeps
// decoded node ids, so later frames only march (and recolour when asked).
struct RenderSession::Labels {
  mixture::EncodedLabels labels;
  render::LabelScene scene;
  std::unique_ptr<LabelShading> normals;  // the file's normals graph, when it has one
  LabelColorMap colors;
  // Per node, for slices: the dominant source (built on first use) and the colour of the
  // visible labels made opaque, so a slice shows coverage, not the 3D opacity.
  std::vector<std::uint32_t> dominant;
  std::vector<float> slice_palette;
  std::optional<std::int64_t> fraction_label;  // the label `fractions` holds
  std::vector<float> fractions;

  Labels(std::unique_ptr<store::ContainerReader> input);
  double frame_radius() const;
  Image frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
              nlohmann::json& stats);
  // Node ids of a slice at its level, in slice order (decode_box's x-fastest order is the
  // slice order), and the slice's width and height.
  std::vector<std::uint32_t> slice_nodes(const SliceSpec& spec, std::pair<int, int>& size) const;
};

// A plain volume file (raw, NRRD, NIfTI, TIFF): loaded whole as floats and ray cast as one
// block, the uncompressed reference a compressed file's rendering can be compared with. Its
// value range and empty-space cells are worked out once, not per frame.
struct RenderSession::Plain {
  DType source_dtype = DType::f32;
  Volume volume;  // f32
  std::pair<double, double> range;  // of the samples
  CasterSlot casters;
  PreparedVolume prepared;

  Plain(const std::filesystem::path& input, std::optional<std::int64_t> volume);
  double frame_radius() const;  // voxels the "ct" preset shows
  Image frame(const Camera& camera, const FrameSettings& settings, const RenderOptions& options, nlohmann::json& stats);
  std::vector<std::uint64_t> histogram() const;
};

// The ray caster options of a frame.
RenderOptions render_options(const FrameSettings& settings, const std::array<float, 4>& background);
// The "ct" preset unless the frame names a transfer function.
const TransferFunction& frame_tf(const FrameSettings& settings);

template <class F>
void RenderSession::Scalar::visit_box(int level, const Box& box, int rank, F&& f) {
  const ta::OctreeGeometry& geometry = volume.geometry();
  const int b = geometry.layout().brick;
  // A slice one voxel thick needs whole B^3 bricks: they are acquired a batch at a time, so a
  // large slice holds at most a batch beyond what the cache keeps.
  constexpr std::size_t kBatch = 64;
  lod::Selection cut;
  auto visit_batch = [&] {
    const lod::FrameBricks bricks = provider.acquire(cut, rank > 0 ? rank : volume.rank(), true);
    for (const lod::ResidentBrick& brick : bricks.bricks) {
      const Box part = geometry.brick_core_box(level, brick.key.x, brick.key.y, brick.key.z).intersect(box);
      const Extent o = geometry.brick_sample_box(level, brick.key.x, brick.key.y, brick.key.z).lo;
      for (std::int64_t z = part.lo.z; z < part.hi.z; ++z)
        for (std::int64_t y = part.lo.y; y < part.hi.y; ++y)
          for (std::int64_t x = part.lo.x; x < part.hi.x; ++x)
            f(x, y, z,
              brick.is_constant() ? brick.constant_value
                                  : (*brick.samples)[std::size_t(((z - o.z) * b + (y - o.y)) * b + (x - o.x))]);
    }
    cut.bricks.clear();
  };
  for_each_brick_in(level, box, [&](const lod::CutBrick& brick) {
    cut.bricks.push_back(brick);
    if (cut.bricks.size() == kBatch) visit_batch();
  });
  if (!cut.bricks.empty()) visit_batch();
}

template <class F>
void RenderSession::Scalar::for_each_brick_in(int level, const Box& box, F&& f) const {
  const int core = volume.geometry().layout().core();
  for (std::int64_t bz = box.lo.z / core; bz <= (box.hi.z - 1) / core; ++bz)
    for (std::int64_t by = box.lo.y / core; by <= (box.hi.y - 1) / core; ++by)
      for (std::int64_t bx = box.lo.x / core; bx <= (box.hi.x - 1) / core; ++bx) {
        const store::BrickKey key{std::uint8_t(level), std::int32_t(bx), std::int32_t(by), std::int32_t(bz)};
        f(lod::CutBrick{key, &volume.entry(key), 0.0, 0.0});
      }
}

}  // namespace strata::render
