#include "ta/level_pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <initializer_list>
#include <span>
#include <utility>

#include "strata/core/error.hpp"
#include "strata/core/hash.hpp"
#include "strata/core/threads.hpp"
#include "strata/tensor/reconstruct.hpp"
#include "ta/non_finite.hpp"


namespace strata::ta {

namespace {

std::int64_t clamp_index(std::int64_t i, std::int64_t n) { return std::min(std::max<std::int64_t>(i, 0), n - 1); }

// ---- Downsampling for the next level --------------------------------------------------------

// The mean of the finite ones of n values; with none, the first of them (NaN stays NaN, an
// infinity stays one). The coarser levels' stand-in for an average that met a NaN or an infinity.
float finite_mean(std::initializer_list<float> values) {
  double sum = 0;
  int count = 0;
  for (float v : values)
    if (std::isfinite(v)) {
      sum += double(v);
      ++count;
    }
  return count > 0 ? float(sum / count) : *values.begin();
}

// 2x2 averages in x and y; an odd last column/row averages with itself. A non-finite result (a
// NaN or infinite voxel among the four) becomes the mean of the finite ones.
void downsample_xy(const float* slice, const Extent& dims, float* out) {
  const Extent half = half_extent(dims);
  for (std::int64_t y = 0; y < half.y; ++y) {
    const float* r0 = slice + 2 * y * dims.x;
    const float* r1 = slice + std::min(2 * y + 1, dims.y - 1) * dims.x;
    float* o = out + y * half.x;
    const std::int64_t pairs = dims.x / 2;  // columns with a partner
    for (std::int64_t x = 0; x < pairs; ++x) {
      o[x] = 0.25f * (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]);
      if (!std::isfinite(o[x])) o[x] = finite_mean({r0[2 * x], r0[2 * x + 1], r1[2 * x], r1[2 * x + 1]});
    }
    if (pairs < half.x) {
      const std::int64_t x0 = dims.x - 1;
      o[pairs] = 0.25f * (r0[x0] + r0[x0] + r1[x0] + r1[x0]);
      if (!std::isfinite(o[pairs])) o[pairs] = finite_mean({r0[x0], r1[x0]});
    }
  }
}

// Two equal halves of a cell, each as (mean, variance about its mean), make the cell's
// (mean, variance) exactly. An odd last column, row or slice pairs with itself, as in the samples.
inline void merge_halves(float mean_a, float var_a, float mean_b, float var_b, float& mean, float& var) {
  const float half_gap = 0.5f * (mean_a - mean_b);
  mean = 0.5f * (mean_a + mean_b);
  var = 0.5f * (var_a + var_b) + half_gap * half_gap;
}

// A reference slice (variance null: 0) reduced 2x2 in x and y.
LevelPipeline::ReferenceSlice reduce_reference_xy(const float* mean, const float* variance, const Extent& dims) {
  const Extent half = half_extent(dims);
  LevelPipeline::ReferenceSlice out{std::vector<float>(std::size_t(half.x * half.y)),
                                    std::vector<float>(std::size_t(half.x * half.y))};
  auto at = [&](std::int64_t x, std::int64_t y, float& m, float& v) {
    const std::int64_t i = y * dims.x + x;
    m = mean[i];
    v = variance ? variance[i] : 0.0f;
  };
  for (std::int64_t hy = 0; hy < half.y; ++hy) {
    const std::int64_t y0 = 2 * hy, y1 = std::min(2 * hy + 1, dims.y - 1);
    for (std::int64_t hx = 0; hx < half.x; ++hx) {
      const std::int64_t x0 = 2 * hx, x1 = std::min(2 * hx + 1, dims.x - 1);
      float m00, v00, m01, v01, m10, v10, m11, v11, ma, va, mb, vb;
      at(x0, y0, m00, v00);
      at(x1, y0, m01, v01);
      at(x0, y1, m10, v10);
      at(x1, y1, m11, v11);
      merge_halves(m00, v00, m01, v01, ma, va);
      merge_halves(m10, v10, m11, v11, mb, vb);
      const std::size_t o = std::size_t(hy * half.x + hx);
      merge_halves(ma, va, mb, vb, out.mean[o], out.variance[o]);
    }
  }
  return out;
}

}  // namespace

// The HOSVD basis costs a brick about as much again as everything else (an eigen-decomposition
// per mode, a second coding and reconstruction), and on most data the block DCT wins. So bricks
// probe it, spread by a hash: about 16 of a level's first row (every 2nd brick at most), every
// 8th of the later rows. Once the probes of this level's finished rows, or of all levels', show
// a saving of 3% or more, every brick tries it. Once 16 probes over all levels show less than 1%
// (and this level's no more), only every 32nd brick keeps probing: data that changes character
// later in the volume, or at a coarser level, is still noticed.
bool LevelPipeline::brick_tries_hosvd(std::int64_t row, std::int64_t index) const {
  constexpr double kAllTryAbove = 0.03, kRareBelow = 0.01;
  constexpr std::uint64_t kFirstRowProbes = 16, kProbeEvery = 8, kRareProbeEvery = 32, kEnoughTrials = 16;
  const HosvdEvidence& all = *hosvd_all_;
  if ((hosvd_level_.trials > 0 && hosvd_level_.saving() >= kAllTryAbove) || (all.trials > 0 && all.saving() >= kAllTryAbove))
    return true;
  const auto bricks_in_row = std::uint64_t(dims_.bricks.x * dims_.bricks.y);
  const bool rare = all.trials >= kEnoughTrials && all.saving() < kRareBelow && hosvd_level_.saving() < kRareBelow;
  const std::uint64_t every = rare       ? kRareProbeEvery
                              : row == 0 ? std::max<std::uint64_t>(2, bricks_in_row / kFirstRowProbes)
                                         : kProbeEvery;
  return splitmix64(std::uint64_t(row) * bricks_in_row + std::uint64_t(index)) % every == 0;
}

LevelPipeline::LevelPipeline(const OctreeGeometry& geometry, int level, const CodecParams& codec, const CodecRun& run,
                             std::optional<BrickTarget> target, HistogramRange range, BrickSink sink, LevelPipeline* next)
    : geometry_(geometry), level_(level), dims_(geometry.level(level)), codec_(codec), run_(run), target_(target),
      range_(range),
      sink_(std::move(sink)), next_(next), feature_reference_(run.codec().needs_feature_reference()),
      end_row_(dims_.bricks.z),
      hosvd_all_(next ? next->hosvd_all_ : std::make_shared<HosvdEvidence>()) {}

void LevelPipeline::restrict_rows(std::int64_t first, std::int64_t end) {
  const BrickLayout& l = geometry_.layout();
  if (slices_received_ != 0 || first < 0 || end <= first || end > dims_.bricks.z || (first * l.core()) % 2 != 0)
    throw Error("compress: level " + std::to_string(level_) + ": cannot restrict to brick rows [" +
                std::to_string(first) + ", " + std::to_string(end) + ")");
  next_row_ = first;
  end_row_ = end;
  window_z0_ = slices_received_ = std::max<std::int64_t>(0, first * l.core() - l.overlap);
  decoded_slices_ = first * l.core();
}

CoreRegion LevelPipeline::core_region(std::int64_t bx, std::int64_t by, std::int64_t bz) const {
  const Box core = geometry_.brick_core_box(level_, bx, by, bz);
  const int overlap = geometry_.layout().overlap;
  CoreRegion r;
  const Extent size = core.size();
  r.lo = {overlap, overlap, overlap};
  r.hi = {overlap + int(size.x), overlap + int(size.y), overlap + int(size.z)};
  r.margin = overlap;
  return r;
}

bool LevelPipeline::row_ready(std::int64_t row) const {
  const BrickLayout& l = geometry_.layout();
  const std::int64_t needed = std::min(dims_.dims.z, (row + 1) * l.core() + l.overlap);
  return slices_received_ >= needed;
}

void LevelPipeline::push_slice(std::vector<float> slice) {
  if (std::int64_t(slice.size()) != dims_.dims.x * dims_.dims.y)
    throw Error("compress: level " + std::to_string(level_) + " received a slice of the wrong size");
  if (feature_reference_ && level_ == 0 && next_) emit_reference(slice.data(), nullptr);
  window_.push_back(std::move(slice));
  ++slices_received_;
  while (next_row_ < end_row_ && row_ready(next_row_)) {
    encode_row(next_row_);
    ++next_row_;
    drop_unneeded_slices(next_row_);
  }
}

void LevelPipeline::push_reference_slice(ReferenceSlice slice) {
  if (std::int64_t(slice.mean.size()) != dims_.dims.x * dims_.dims.y || slice.variance.size() != slice.mean.size())
    throw Error("compress: level " + std::to_string(level_) + " received a reference slice of the wrong size");
  if (next_) emit_reference(slice.mean.data(), slice.variance.data());
  reference_window_.push_back(std::move(slice));
}

void LevelPipeline::emit_reference(const float* mean, const float* variance) {
  ReferenceSlice h = reduce_reference_xy(mean, variance, dims_.dims);
  ++reference_slices_;
  if (!pending_reference_) {
    pending_reference_ = std::move(h);
    // An odd last slice has no partner: it stands for itself in the coarser level.
    if (reference_slices_ == dims_.dims.z) next_->push_reference_slice(*std::exchange(pending_reference_, std::nullopt));
    return;
  }
  ReferenceSlice& a = *pending_reference_;
  for (std::size_t i = 0; i < a.mean.size(); ++i)
    merge_halves(a.mean[i], a.variance[i], h.mean[i], h.variance[i], a.mean[i], a.variance[i]);
  next_->push_reference_slice(*std::exchange(pending_reference_, std::nullopt));
}

double LevelPipeline::gather_reference(std::int64_t bx, std::int64_t by, std::int64_t bz, tensor::Tensor3& means) const {
  const BrickLayout& l = geometry_.layout();
  const Box core = geometry_.brick_core_box(level_, bx, by, bz);
  const std::int64_t ox = core.lo.x - l.overlap, oy = core.lo.y - l.overlap, oz = core.lo.z - l.overlap;
  double variance = 0;
  for (std::int64_t z = core.lo.z; z < core.hi.z; ++z) {
    if (z < reference_z0_ || z - reference_z0_ >= std::int64_t(reference_window_.size()))
      throw Error("compress: level " + std::to_string(level_) + " lacks reference slice " + std::to_string(z));
    const ReferenceSlice& slice = reference_window_[std::size_t(z - reference_z0_)];
    for (std::int64_t y = core.lo.y; y < core.hi.y; ++y)
      for (std::int64_t x = core.lo.x; x < core.hi.x; ++x) {
        const std::size_t i = std::size_t(y * dims_.dims.x + x);
        means(x - ox, y - oy, z - oz) = slice.mean[i];
        variance += double(slice.variance[i]);
      }
  }
  return variance / double(core.size().voxel_count());
}

void LevelPipeline::finish() {
  // The slices rows [.., end_row_) read: the whole level unless restrict_rows() said otherwise.
  const BrickLayout& l = geometry_.layout();
  const std::int64_t expected = std::min(dims_.dims.z, end_row_ * l.core() + l.overlap);
  if (slices_received_ != expected)
    throw Error("compress: level " + std::to_string(level_) + " received " + std::to_string(slices_received_) +
                " slices, expected " + std::to_string(expected));
  while (next_row_ < end_row_) {
    encode_row(next_row_);
    ++next_row_;
  }
  if (next_) next_->finish();
}

void LevelPipeline::drop_unneeded_slices(std::int64_t next_row) {
  const BrickLayout& l = geometry_.layout();
  const std::int64_t keep_from = std::max<std::int64_t>(0, next_row * l.core() - l.overlap);
  while (window_z0_ < keep_from && !window_.empty()) {
    window_.pop_front();
    ++window_z0_;
  }
  while (reference_z0_ < keep_from && !reference_window_.empty()) {
    reference_window_.pop_front();
    ++reference_z0_;
  }
}

void LevelPipeline::gather_samples(std::int64_t bx, std::int64_t by, std::int64_t bz, tensor::Tensor3& out) const {
  const Box box = geometry_.brick_sample_box(level_, bx, by, bz);
  const Extent& d = dims_.dims;
  const std::int64_t b = geometry_.layout().brick;
  // Columns [i0, i1) of the brick lie inside the level and are copied as a block; the others
  // repeat the edge voxel.
  const std::int64_t i0 = std::clamp<std::int64_t>(-box.lo.x, 0, b), i1 = std::clamp<std::int64_t>(d.x - box.lo.x, i0, b);
  // The B^2 source rows are short pieces of B floats spread over B slices of the level: mostly
  // cache misses. Their addresses are known up front, so each row is prefetched a few rows
  // ahead of its copy and the misses overlap instead of queueing one after the other.
  thread_local std::vector<const float*> rows;
  rows.resize(std::size_t(b * b));
  for (std::int64_t k = 0; k < b; ++k) {
    const float* slice = window_.at(std::size_t(clamp_index(box.lo.z + k, d.z) - window_z0_)).data();
    for (std::int64_t j = 0; j < b; ++j) rows[std::size_t(k * b + j)] = slice + clamp_index(box.lo.y + j, d.y) * d.x;
  }
  constexpr std::int64_t kAhead = 12;
  const std::int64_t count = b * b, bytes = (i1 - i0) * std::int64_t(sizeof(float));
  auto prefetch = [&](std::int64_t r) {
    const char* p = reinterpret_cast<const char*>(rows[std::size_t(r)] + (box.lo.x + i0));
    for (std::int64_t offset = 0; offset < bytes; offset += 64) __builtin_prefetch(p + offset);
    __builtin_prefetch(p + bytes - 1);
  };
  for (std::int64_t r = 0; r < std::min(kAhead, count); ++r) prefetch(r);
  for (std::int64_t r = 0; r < count; ++r) {
    if (r + kAhead < count) prefetch(r + kAhead);
    const float* row = rows[std::size_t(r)];
    float* dst = out.data() + r * b;
    for (std::int64_t i = 0; i < i0; ++i) dst[i] = row[0];
    std::memcpy(dst + i0, row + (box.lo.x + i0), std::size_t(i1 - i0) * sizeof(float));
    for (std::int64_t i = i1; i < b; ++i) dst[i] = row[d.x - 1];
  }
}

void LevelPipeline::downsample_core(std::span<const float> decoded, std::int64_t bx, std::int64_t by,
                                    std::int64_t bz) {
  const BrickLayout& l = geometry_.layout();
  const Extent& d = dims_.dims;
  const Extent half = half_extent(d);
  const Box core = geometry_.brick_core_box(level_, bx, by, bz);
  const std::int64_t b = l.brick;
  // Brick-local offsets of the level's voxels: x_local = x - ox, etc.
  const std::int64_t ox = core.lo.x - l.overlap, oy = core.lo.y - l.overlap, oz = core.lo.z - l.overlap;
  auto row_of = [&](std::int64_t y, std::int64_t z) { return decoded.data() + ((z - oz) * b + (y - oy)) * b; };
  const std::int64_t hz0 = bz * l.core() / 2;  // first half slice of this row
  const std::int64_t hx0 = core.lo.x / 2, pairs_end = hx0 + (core.hi.x - core.lo.x) / 2;
  // Same arithmetic, in the same order, as downsample_xy followed by the pair average.
  for (std::int64_t hz = core.lo.z / 2; hz < (core.hi.z + 1) / 2; ++hz) {
    const std::int64_t za = 2 * hz, zb = 2 * hz + 1;
    const bool pair = zb < d.z;  // an odd last slice stands for itself
    float* out_slice = next_slices_.data() + (hz - hz0) * half.x * half.y;
    for (std::int64_t hy = core.lo.y / 2; hy < (core.hi.y + 1) / 2; ++hy) {
      const std::int64_t ya = 2 * hy, yb = std::min(2 * hy + 1, d.y - 1);
      const float *a0 = row_of(ya, za), *a1 = row_of(yb, za);
      const float *b0 = row_of(ya, pair ? zb : za), *b1 = row_of(yb, pair ? zb : za);
      float* o = out_slice + hy * half.x;
      // A non-finite average (a NaN or infinite voxel among the eight) becomes the mean of the
      // finite ones; finite ones keep their exact arithmetic.
      if (pair) {
        for (std::int64_t hx = hx0; hx < pairs_end; ++hx) {
          const std::int64_t x = 2 * hx - ox;
          const float h0 = 0.25f * (a0[x] + a0[x + 1] + a1[x] + a1[x + 1]);
          const float h1 = 0.25f * (b0[x] + b0[x + 1] + b1[x] + b1[x + 1]);
          o[hx] = 0.5f * (h0 + h1);
          if (!std::isfinite(o[hx]))
            o[hx] = finite_mean({a0[x], a0[x + 1], a1[x], a1[x + 1], b0[x], b0[x + 1], b1[x], b1[x + 1]});
        }
      } else {
        for (std::int64_t hx = hx0; hx < pairs_end; ++hx) {
          const std::int64_t x = 2 * hx - ox;
          o[hx] = 0.25f * (a0[x] + a0[x + 1] + a1[x] + a1[x + 1]);
          if (!std::isfinite(o[hx])) o[hx] = finite_mean({a0[x], a0[x + 1], a1[x], a1[x + 1]});
        }
      }
      if (pairs_end < (core.hi.x + 1) / 2) {  // odd last column (level edge): averages with itself
        const std::int64_t x = d.x - 1 - ox;
        const float h0 = 0.25f * (a0[x] + a0[x] + a1[x] + a1[x]);
        o[pairs_end] = pair ? 0.5f * (h0 + 0.25f * (b0[x] + b0[x] + b1[x] + b1[x])) : h0;
        if (!std::isfinite(o[pairs_end]))
          o[pairs_end] = pair ? finite_mean({a0[x], a1[x], b0[x], b1[x]}) : finite_mean({a0[x], a1[x]});
      }
    }
  }
}

bool LevelPipeline::encode_and_decode(std::int64_t bx, std::int64_t by, std::int64_t bz, const tensor::Tensor3& samples,
                                      std::vector<float>& decoded, EncodedBrick& encoded,
                                      tensor::BrickReconstructor& reconstructor, DecodeScratch& scratch,
                                      bool try_hosvd) const {
  std::optional<BrickTarget> target = target_;
  if (target) target->try_hosvd = try_hosvd;
  BrickJob job{level_, bx, by, bz, &samples, core_region(bx, by, bz), target ? &*target : nullptr, has_next(), {}};
  if (feature_reference_ && level_ > 0)
    job.reference = [this, bx, by, bz](tensor::Tensor3& means) { return gather_reference(bx, by, bz, means); };
  return run_.encode(job, decoded, encoded, reconstructor, scratch);
}

void LevelPipeline::encode_row(std::int64_t row) {
  const BrickLayout& l = geometry_.layout();
  const Extent& d = dims_.dims;
  const std::int64_t z0 = row * l.core(), z1 = std::min(d.z, (row + 1) * l.core());
  // Buffers for the next level are kept between rows (no page faults for a fresh multi-megabyte
  // allocation per row) and need no clearing: every voxel lies in exactly one brick core.
  const bool per_brick = has_next() && l.core() % 2 == 0;
  const Extent half = half_extent(d);
  if (per_brick) next_slices_.resize(std::size_t((z1 - z0 + 1) / 2 * half.x * half.y));
  else if (has_next()) decoded_row_.resize(std::size_t((z1 - z0) * d.x * d.y));
  const std::int64_t bricks_in_row = dims_.bricks.x * dims_.bricks.y;
  // Results are handed to the sink in brick order after the parallel loop, so the file's bytes
  // do not depend on which thread finishes first; errors are carried out of the OpenMP region
  // (an exception escaping it would terminate the program).
  struct RowResult {
    EncodedBrick encoded;
    BrickStats stats;
    CoreError error;
  };
  std::vector<RowResult> results(static_cast<std::size_t>(bricks_in_row));
  std::exception_ptr failure;

#pragma omp parallel num_threads(thread_count())
  {
    tensor::Tensor3 samples(l.brick, l.brick, l.brick);
    std::vector<float> decoded(std::size_t(samples.size()));
    tensor::BrickReconstructor reconstructor;
    DecodeScratch scratch;
#pragma omp for schedule(dynamic)
    for (std::int64_t i = 0; i < bricks_in_row; ++i) {
      try {
        const std::int64_t bx = i % dims_.bricks.x, by = i / dims_.bricks.x;
        gather_samples(bx, by, row, samples);
        RowResult& r = results[std::size_t(i)];
        const NonFiniteMask mask = has_non_finite(samples.values()) ? take_non_finite(samples.values(), samples.dims())
                                                                  : NonFiniteMask{};
        if (!run_.codec().stores_non_finite() && !mask.empty())
          throw Error("the " + std::string(run_.codec().name()) + " codec does not store NaN or infinite voxels yet (level " +
                      std::to_string(level_) + " brick " + std::to_string(bx) + "," + std::to_string(by) + "," +
                      std::to_string(row) + " has some); compress with the default codec, " + kBrickedCodecName);
        if (uniform_non_finite(mask, decoded.size())) {
          // All NaN (outside a field of view) or all one infinity: a constant brick of it.
          r.encoded = EncodedBrick{};
          r.encoded.constant_value = mask.value[0];
          std::fill(decoded.begin(), decoded.end(), mask.value[0]);
          r.stats = brick_stats(std::span(&mask.value[0], 1), std::span(&mask.value[0], 1), range_);
        } else {
          // Culling metadata covers what a renderer may sample: original and decoded values (of
          // the finite voxels: the masked ones hold the same stand-in in both). A constant
          // brick decodes to its value, which stands for every sample (an error-target brick
          // may be constant within its bound).
          const bool constant = encode_and_decode(bx, by, row, samples, decoded, r.encoded, reconstructor, scratch,
                                                  brick_tries_hosvd(row, i));
          const float c = r.encoded.constant_value;
          if (!mask.empty()) {
            if (constant) std::fill(decoded.begin(), decoded.end(), c);
            copy_masked(mask, samples.values(), decoded);  // the stand-in on both sides
          }
          r.stats = constant && mask.empty() ? brick_stats(std::span(&c, 1), std::span(&c, 1), range_)
                                             : brick_stats(decoded, samples.values(), range_);
          const CoreRegion core = core_region(bx, by, row);
          if (target_) r.error = core_error(samples.values(), decoded, samples.dims(), core);
          if (!mask.empty()) {
            r.error.voxels -= masked_in_core(mask, samples.dims(), core);  // their error is 0: not counted
            wrap_with_mask(mask, decoded.size(), codec_.zstd_level, r.encoded);
            restore_non_finite(mask, decoded);
          }
        }
        if (per_brick) {
          downsample_core(decoded, bx, by, row);
        } else if (has_next()) {
          // Keep the decoded core for the parent level.
          const Box core = geometry_.brick_core_box(level_, bx, by, row);
          for (std::int64_t z = core.lo.z; z < core.hi.z; ++z)
            for (std::int64_t y = core.lo.y; y < core.hi.y; ++y) {
              const std::int64_t local_z = z - (core.lo.z - l.overlap), local_y = y - (by * l.core() - l.overlap);
              const float* src = decoded.data() + (local_z * l.brick + local_y) * l.brick + l.overlap;
              float* dst = decoded_row_.data() + ((z - z0) * d.y + y) * d.x + core.lo.x;
              std::memcpy(dst, src, std::size_t(core.hi.x - core.lo.x) * sizeof(float));
            }
        }
      } catch (...) {
#pragma omp critical(strata_encode_row_failure)
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  for (std::int64_t i = 0; i < bricks_in_row; ++i) {
    const std::int64_t bx = i % dims_.bricks.x, by = i / dims_.bricks.x;
    const store::BrickKey key{std::uint8_t(level_), std::int32_t(bx), std::int32_t(by), std::int32_t(row)};
    RowResult& r = results[std::size_t(i)];
    sink_(key, r.encoded, r.stats.lo, r.stats.hi, r.stats.bits);
    measured_.squared += r.error.squared;
    measured_.max_abs = std::max(measured_.max_abs, r.error.max_abs);
    measured_.voxels += r.error.voxels;
    if (r.encoded.block_dct_bytes > 0) {
      const std::size_t kept = std::min(r.encoded.block_dct_bytes, r.encoded.hosvd_bytes);
      for (HosvdEvidence* e : {&hosvd_level_, hosvd_all_.get()}) {
        ++e->trials;
        e->trial_bytes += r.encoded.block_dct_bytes;
        e->saved_bytes += r.encoded.block_dct_bytes - kept;
      }
    }
  }
  if (per_brick) {
    const std::size_t half_size = std::size_t(half.x * half.y);
    for (std::int64_t hz = 0; hz < (z1 - z0 + 1) / 2; ++hz) {
      const float* s = next_slices_.data() + std::size_t(hz) * half_size;
      hand_on(std::vector<float>(s, s + half_size));
    }
    decoded_slices_ += z1 - z0;
  } else if (has_next()) {
    emit_decoded_slices(z0, z1);
  }
}

// Slice pairs (2k, 2k + 1) of this level become slice k of the next: each slice is averaged 2x2
// in x and y, then the pair is averaged; an odd last slice stands for itself. A pair may straddle
// two rows when the core width is odd, hence pending_decoded_.
void LevelPipeline::emit_decoded_slices(std::int64_t z0, std::int64_t z1) {
  const Extent& d = dims_.dims;
  const Extent half = half_extent(d);
  const std::size_t slice_size = std::size_t(d.x * d.y), half_size = std::size_t(half.x * half.y);
  std::vector<float> h(half_size);
  for (std::int64_t z = z0; z < z1; ++z) {
    const float* slice = decoded_row_.data() + std::size_t(z - z0) * slice_size;
    ++decoded_slices_;
    if (pending_decoded_.empty()) {
      pending_decoded_.resize(half_size);
      downsample_xy(slice, d, pending_decoded_.data());
      // An odd last slice has no partner: it stands for itself in the coarser level.
      if (decoded_slices_ == d.z) hand_on(std::exchange(pending_decoded_, {}));
      continue;
    }
    downsample_xy(slice, d, h.data());
    for (std::size_t i = 0; i < half_size; ++i) {
      const float mean = 0.5f * (pending_decoded_[i] + h[i]);
      pending_decoded_[i] = std::isfinite(mean) ? mean : finite_mean({pending_decoded_[i], h[i]});
    }
    hand_on(std::exchange(pending_decoded_, {}));
  }
}

}  // namespace strata::ta
