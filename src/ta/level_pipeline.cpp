#include "ta/level_pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <exception>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::ta {

namespace {

std::int64_t clamp_index(std::int64_t i, std::int64_t n) { return std::min(std::max<std::int64_t>(i, 0), n - 1); }

// Bit i set when some value falls into bin i of 64 equal bins over [lo, hi].
std::uint64_t histogram_bits(std::span<const float> values, const HistogramRange& range) {
  const double scale = range.hi > range.lo ? 64.0 / (range.hi - range.lo) : 0.0;
  std::uint64_t bits = 0;
  for (float v : values) {
    const auto bin = std::int64_t((double(v) - range.lo) * scale);
    bits |= std::uint64_t(1) << std::clamp<std::int64_t>(bin, 0, 63);
  }
  return bits;
}

// 2x2 averages in x and y; an odd last column/row averages with itself.
std::vector<float> downsample_xy(const std::vector<float>& slice, const Extent& dims) {
  const Extent half = half_extent(dims);
  std::vector<float> out(std::size_t(half.x * half.y));
  for (std::int64_t y = 0; y < half.y; ++y) {
    const float* r0 = slice.data() + 2 * y * dims.x;
    const float* r1 = slice.data() + std::min(2 * y + 1, dims.y - 1) * dims.x;
    for (std::int64_t x = 0; x < half.x; ++x) {
      const std::int64_t x0 = 2 * x, x1 = std::min(2 * x + 1, dims.x - 1);
      out[std::size_t(y * half.x + x)] = 0.25f * (r0[x0] + r0[x1] + r1[x0] + r1[x1]);
    }
  }
  return out;
}

}  // namespace

LevelPipeline::LevelPipeline(const OctreeGeometry& geometry, int level, const CodecParams& codec,
                             HistogramRange range, BrickSink sink, LevelPipeline* next)
    : geometry_(geometry), level_(level), dims_(geometry.level(level)), codec_(codec), range_(range),
      sink_(std::move(sink)), next_(next) {}

bool LevelPipeline::row_ready(std::int64_t row) const {
  const BrickLayout& l = geometry_.layout();
  const std::int64_t needed = std::min(dims_.dims.z, (row + 1) * l.core() + l.overlap);
  return slices_received_ >= needed;
}

void LevelPipeline::push_slice(std::vector<float> slice) {
  if (std::int64_t(slice.size()) != dims_.dims.x * dims_.dims.y)
    throw Error("compress: level " + std::to_string(level_) + " received a slice of the wrong size");
  window_.push_back(std::move(slice));
  ++slices_received_;
  while (next_row_ < dims_.bricks.z && row_ready(next_row_)) {
    encode_row(next_row_);
    ++next_row_;
    drop_unneeded_slices(next_row_);
  }
}

void LevelPipeline::finish() {
  if (slices_received_ != dims_.dims.z)
    throw Error("compress: level " + std::to_string(level_) + " received " + std::to_string(slices_received_) +
                " slices, expected " + std::to_string(dims_.dims.z));
  while (next_row_ < dims_.bricks.z) {
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
}

void LevelPipeline::gather_samples(std::int64_t bx, std::int64_t by, std::int64_t bz, Tensor3& out) const {
  const Box box = geometry_.brick_sample_box(level_, bx, by, bz);
  const Extent& d = dims_.dims;
  const std::int64_t b = geometry_.layout().brick;
  for (std::int64_t k = 0; k < b; ++k) {
    const std::int64_t z = clamp_index(box.lo.z + k, d.z);
    const std::vector<float>& slice = window_.at(std::size_t(z - window_z0_));
    for (std::int64_t j = 0; j < b; ++j) {
      const float* row = slice.data() + clamp_index(box.lo.y + j, d.y) * d.x;
      float* dst = &out(0, j, k);
      for (std::int64_t i = 0; i < b; ++i) dst[i] = row[clamp_index(box.lo.x + i, d.x)];
    }
  }
}

void LevelPipeline::encode_row(std::int64_t row) {
  const BrickLayout& l = geometry_.layout();
  const Extent& d = dims_.dims;
  const std::int64_t z0 = row * l.core(), z1 = std::min(d.z, (row + 1) * l.core());
  std::vector<float> decoded_row(std::size_t((z1 - z0) * d.x * d.y));
  const std::int64_t bricks_in_row = dims_.bricks.x * dims_.bricks.y;
  // Results are handed to the sink in brick order after the parallel loop, so the file's bytes
  // do not depend on which thread finishes first; errors are carried out of the OpenMP region
  // (an exception escaping it would terminate the program).
  struct RowResult {
    EncodedBrick encoded;
    float min = 0, max = 0;
    std::uint64_t histogram = 0;
  };
  std::vector<RowResult> results(static_cast<std::size_t>(bricks_in_row));
  std::exception_ptr failure;

#pragma omp parallel num_threads(thread_count())
  {
    Tensor3 samples(l.brick, l.brick, l.brick);
    std::vector<float> decoded(std::size_t(samples.size()));
    BrickReconstructor reconstructor;
    DecodeScratch scratch;
#pragma omp for schedule(dynamic)
    for (std::int64_t i = 0; i < bricks_in_row; ++i) {
      try {
        const std::int64_t bx = i % dims_.bricks.x, by = i / dims_.bricks.x;
        gather_samples(bx, by, row, samples);
        RowResult& r = results[std::size_t(i)];
        r.encoded = encode_brick(samples, codec_);
        decode_brick(r.encoded.kind, r.encoded.payload, r.encoded.constant_value, codec_.quant, l.brick, codec_.rank,
                     reconstructor, scratch, decoded, "compress");
        // Culling metadata covers what a renderer may sample: original and decoded values.
        auto [lo_it, hi_it] = std::minmax_element(decoded.begin(), decoded.end());
        auto [slo_it, shi_it] = std::minmax_element(samples.values().begin(), samples.values().end());
        r.min = std::min(*lo_it, *slo_it);
        r.max = std::max(*hi_it, *shi_it);
        r.histogram = histogram_bits(decoded, range_) | histogram_bits(samples.values(), range_);
        // Keep the decoded core for the parent level.
        const Box core = geometry_.brick_core_box(level_, bx, by, row);
        for (std::int64_t z = core.lo.z; z < core.hi.z; ++z)
          for (std::int64_t y = core.lo.y; y < core.hi.y; ++y) {
            const std::int64_t local_z = z - (core.lo.z - l.overlap), local_y = y - (by * l.core() - l.overlap);
            const float* src = decoded.data() + (local_z * l.brick + local_y) * l.brick + l.overlap;
            float* dst = decoded_row.data() + ((z - z0) * d.y + y) * d.x + core.lo.x;
            std::copy(src, src + (core.hi.x - core.lo.x), dst);
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
    sink_(key, r.encoded, r.min, r.max, r.histogram);
  }
  if (!next_) return;
  const std::size_t slice_size = std::size_t(d.x * d.y);
  for (std::int64_t z = z0; z < z1; ++z)
    emit_decoded_slice(std::vector<float>(decoded_row.begin() + std::ptrdiff_t((z - z0) * slice_size),
                                          decoded_row.begin() + std::ptrdiff_t((z - z0 + 1) * slice_size)));
}

void LevelPipeline::emit_decoded_slice(std::vector<float> slice) {
  std::vector<float> half = downsample_xy(slice, dims_.dims);
  ++decoded_slices_;
  if (pending_decoded_.empty()) {
    pending_decoded_ = std::move(half);
    // An odd last slice has no partner: it stands for itself in the coarser level.
    if (decoded_slices_ == dims_.dims.z) next_->push_slice(std::exchange(pending_decoded_, {}));
    return;
  }
  for (std::size_t i = 0; i < half.size(); ++i) pending_decoded_[i] = 0.5f * (pending_decoded_[i] + half[i]);
  next_->push_slice(std::exchange(pending_decoded_, {}));
}

}  // namespace strata::ta
