#pragma once
// The streaming engine of the compressor. One LevelPipeline per octree level receives that
// level's slices in z order, encodes a row of bricks as soon as the slices it needs (core plus
// overlap, clamped at the edges) have arrived, decodes the row's cores, and feeds their 2x2x2
// averages to the next coarser level. Parents are thus built from their decoded children, as
// in paper 1 §3, and memory stays at a few brick rows per level.
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "strata/store/container.hpp"
#include "strata/ta/brick_codec.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/global_basis.hpp"
#include "strata/ta/octree.hpp"
#include "strata/ta/target_codec.hpp"
#include "ta/brick_stats.hpp"

namespace strata::ta {

// Called for every encoded brick (from worker threads; must be thread-safe).
using BrickSink = std::function<void(const store::BrickKey&, const EncodedBrick&, float min, float max,
                                     std::uint64_t histogram)>;

class LevelPipeline {
 public:
  // `run` encodes the bricks (ta/codec_registry.hpp; it outlives the pipeline); `codec` holds the
  // zstd level of the masks of bricks with NaN or infinite voxels. `target`: this level's brick
  // target in error-target mode (ta/target_codec.hpp), else empty.
  LevelPipeline(const OctreeGeometry& geometry, int level, const CodecParams& codec, const CodecRun& run,
                std::optional<BrickTarget> target, HistogramRange range, BrickSink sink, LevelPipeline* next);

  // Distributed compression (src/dist): this pipeline encodes only brick rows [first, end) of its
  // level. Its first pushed slice is then the first slice those rows read (first * core -
  // overlap, clamped at 0); first * core must be even, so that no 2x2x2 block of the next level
  // straddles two ranges. The bytes of each brick are those of the whole-volume pipeline.
  void restrict_rows(std::int64_t first, std::int64_t end);
  // Hands the next level's slices (in z order, from slice first * core / 2 on) to `forward`
  // instead of a next pipeline (`next` must be null).
  void forward_slices(std::function<void(std::vector<float>)> forward) { forward_ = std::move(forward); }

  // Appends the next slice (dims.x * dims.y floats) of this level.
  void push_slice(std::vector<float> slice);

  // Codecs that need a feature reference (ta-global), coarse levels: the reference the
  // feature-scale table is measured against (paper 2
  // §4.2, "against the original"). Each voxel of level l stands for a cell of 2^l x 2^l x 2^l
  // original voxels; `mean` is the original's mean over the cell and `variance` its variance about
  // that mean. A brick upsampled cell by cell then has the squared error variance + (mean -
  // reconstruction)^2 per cell against the original, exactly. Level 0 makes them from its input
  // slices and each level hands them on, ahead of the samples, which wait for encoding.
  struct ReferenceSlice {
    std::vector<float> mean, variance;
  };
  void push_reference_slice(ReferenceSlice slice);
  // Call once every slice has been pushed: encodes the remaining rows and finishes `next`.
  void finish();

  // Error-target mode: the decoded level against the samples it was encoded from (the level
  // built from decoded children for coarse levels), summed in brick order.
  const CoreError& measured_error() const { return measured_; }

 private:
  bool row_ready(std::int64_t row) const;
  void encode_row(std::int64_t row);
  // Encodes one brick and leaves its decoded samples in `decoded` (not for a constant brick of a
  // last level: nobody reads them). Returns whether the brick became a constant brick.
  bool encode_and_decode(std::int64_t bx, std::int64_t by, std::int64_t bz, const tensor::Tensor3& samples,
                         std::vector<float>& decoded, EncodedBrick& encoded, tensor::BrickReconstructor& reconstructor,
                         DecodeScratch& scratch, bool try_hosvd) const;
  // Error-target mode: whether brick `index` of `row` (x fastest) also tries the HOSVD basis:
  // every brick while the basis has saved at least 3% of the bytes of the bricks that tried it
  // in finished rows (smooth fields: 30-50 %), otherwise hashed probes (rules beside the code).
  // The HOSVD costs about as much CPU as the rest of the encoder: on MRI and EM it saves under
  // 1 %, so trying it everywhere halved the speed for nothing. Decided from finished rows and
  // the brick's index only: the same on any thread count.
  bool brick_tries_hosvd(std::int64_t row, std::int64_t index) const;
  void gather_samples(std::int64_t bx, std::int64_t by, std::int64_t bz, tensor::Tensor3& out) const;
  bool has_next() const { return next_ != nullptr || forward_ != nullptr; }
  void hand_on(std::vector<float> slice) { next_ ? next_->push_slice(std::move(slice)) : forward_(std::move(slice)); }
  // Feeds decoded slices [z0, z1) (in decoded_row_) to `next` as 2x2x2 averages.
  void emit_decoded_slices(std::int64_t z0, std::int64_t z1);
  // With an even core width every 2x2x2 block lies in one brick core: the brick writes its share
  // of the next level's slices (next_slices_) directly from its decoded voxels.
  void downsample_core(std::span<const float> decoded, std::int64_t bx, std::int64_t by, std::int64_t bz);
  void drop_unneeded_slices(std::int64_t next_row);
  // Reduces one reference slice of this level (variance null: 0, the original itself) 2x2 in x
  // and y and pairs it with the previous one for `next`.
  void emit_reference(const float* mean, const float* variance);
  // ta-global, level >= 1: the reference means at the brick's core voxels (brick-local, in
  // `means`) and the mean of the reference variance over them.
  double gather_reference(std::int64_t bx, std::int64_t by, std::int64_t bz, tensor::Tensor3& means) const;
  // The brick-local voxels of the brick's core (what the level's output takes from it).
  CoreRegion core_region(std::int64_t bx, std::int64_t by, std::int64_t bz) const;

  const OctreeGeometry& geometry_;
  int level_;
  LevelGeometry dims_;
  CodecParams codec_;
  const CodecRun& run_;
  std::optional<BrickTarget> target_;
  HistogramRange range_;
  BrickSink sink_;
  LevelPipeline* next_;
  std::function<void(std::vector<float>)> forward_;  // instead of next_ (restrict_rows)
  bool feature_reference_;  // the codec needs the original's cell means (BrickJob::reference)

  std::deque<std::vector<float>> window_;  // input slices [window_z0_, window_z0_ + size)
  std::int64_t window_z0_ = 0, slices_received_ = 0, next_row_ = 0;
  std::int64_t end_row_;  // rows [next_row_, end_row_) are still to encode
  std::vector<float> decoded_row_;        // decoded brick cores of the current row (odd core), reused
  std::vector<float> next_slices_;        // the row's 2x2x2 averages for `next` (even core), reused
  std::vector<float> pending_decoded_;     // one decoded slice (2x2 averaged) awaiting its partner
  std::int64_t decoded_slices_ = 0;
  std::deque<ReferenceSlice> reference_window_;  // reference slices [reference_z0_, ...)
  std::int64_t reference_z0_ = 0, reference_slices_ = 0;
  std::optional<ReferenceSlice> pending_reference_;  // reduced in x and y, awaiting its z partner
  CoreError measured_;
  // What the HOSVD basis saved on the bricks that coded both bases, in this level's finished
  // rows and in those of every level (shared by the pipelines of one volume).
  struct HosvdEvidence {
    std::uint64_t trials = 0, trial_bytes = 0, saved_bytes = 0;
    double saving() const { return trial_bytes > 0 ? double(saved_bytes) / double(trial_bytes) : 0.0; }
  };
  HosvdEvidence hosvd_level_;
  std::shared_ptr<HosvdEvidence> hosvd_all_;
};

}  // namespace strata::ta
