#include "strata/core/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace strata {


void StatisticsAccumulator::add_sample(double v) {
  // Keep every stride-th value; when full, drop every other one and double the stride, so
  // the kept values stay evenly spread over the whole stream.
  if (++sample_phase_ < sample_stride_) return;
  sample_phase_ = 0;
  samples_.push_back(v);
  if (samples_.size() >= kSampleCap) {
    std::size_t j = 0;
    for (std::size_t i = 0; i < samples_.size(); i += 2) samples_[j++] = samples_[i];
    samples_.resize(j);
    sample_stride_ *= 2;
  }
}

template <class T>
void StatisticsAccumulator::add_typed(const T* v, std::int64_t n) {
  double sum = 0, sum_sq = 0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
  std::uint64_t zeros = 0, nan = 0, positive_infinite = 0, negative_infinite = 0;
#pragma omp parallel for reduction(+ : sum, sum_sq, zeros, nan, positive_infinite, negative_infinite) \
    reduction(min : lo) reduction(max : hi) schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const double x = double(v[i]);
    zeros += (v[i] == T(0));
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(x)) {
        nan += std::isnan(x);
        positive_infinite += x > 0;
        negative_infinite += x < 0;
        continue;
      }
    }
    sum += x;
    sum_sq += x * x;
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  if (n == 0) return;
  const std::uint64_t finite = std::uint64_t(n) - nan - positive_infinite - negative_infinite;
  if (finite > 0) {
    min_ = finite_ ? std::min(min_, lo) : lo;
    max_ = finite_ ? std::max(max_, hi) : hi;
  }
  n_ += std::uint64_t(n);
  finite_ += finite;
  sum_ += sum;
  sum_sq_ += sum_sq;
  zeros_ += zeros;
  nan_ += nan;
  positive_infinite_ += positive_infinite;
  negative_infinite_ += negative_infinite;

  if constexpr (std::is_floating_point_v<T>) {
    seen_float_ = true;
    for (std::int64_t i = 0; i < n; ++i)
      if (std::isfinite(v[i])) add_sample(double(v[i]));
  } else if constexpr (sizeof(T) <= 2) {
    // Signed types are shifted by 32768 so every 8/16-bit value has its own table entry.
    small_offset_ = std::is_signed_v<T> ? 32768 : 0;
    if (small_counts_.empty()) small_counts_.assign(65536, 0);
    for (std::int64_t i = 0; i < n; ++i) ++small_counts_[std::size_t(std::int64_t(v[i]) + small_offset_)];
  } else {
    // Label volumes come in long runs of one id: count runs, not voxels, in the hash map. Once
    // the map holds more distinct values than the cap, it is frozen (its counts stay exact for
    // the voxels before) and the rest of the stream is sampled for the histogram.
    std::int64_t i = 0;
    while (i < n && !distinct_overflow_) {
      std::int64_t j = i + 1;
      while (j < n && v[j] == v[i]) ++j;
      counts_[std::int64_t(v[i])] += std::uint64_t(j - i);
      if (counts_.size() > kDistinctCap) distinct_overflow_ = true;
      i = j;
    }
    for (std::int64_t k = i; k < n; ++k) add_sample(double(v[k]));
  }
}

void StatisticsAccumulator::add(const Volume& slab) {
  visit_dtype(slab.dtype(), [&](auto tag) {
    using T = decltype(tag);
    add_typed(slab.samples<T>().data(), slab.voxel_count());
  });
}

VolumeStatistics StatisticsAccumulator::result() const {
  VolumeStatistics s;
  s.voxel_count = n_;
  s.nan_count = nan_;
  s.positive_infinity_count = positive_infinite_;
  s.negative_infinity_count = negative_infinite_;
  if (n_ == 0) return s;
  s.zero_fraction = double(zeros_) / double(n_);
  if (finite_ == 0) {
    s.min = s.max = s.mean = s.stddev = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  s.min = min_;
  s.max = max_;
  s.mean = sum_ / double(finite_);
  s.stddev = std::sqrt(std::max(0.0, sum_sq_ / double(finite_) - s.mean * s.mean));
  const double range = max_ - min_;
  // Finite values only, so no bin index comes from a cast of NaN or infinity.
  auto bin_of = [&](double v) {
    const double bins = double(s.histogram.size());
    const double t = range > 0 ? (v - min_) / range * bins : 0.0;
    if (!(t >= 1.0)) return std::size_t(0);
    return t >= bins ? s.histogram.size() - 1 : std::size_t(t);
  };
  if (!small_counts_.empty()) {
    std::uint64_t distinct = 0;
    for (std::size_t i = 0; i < small_counts_.size(); ++i) {
      if (!small_counts_[i]) continue;
      ++distinct;
      s.histogram[bin_of(double(std::int64_t(i) - small_offset_))] += small_counts_[i];
    }
    s.distinct_values = distinct;
  } else {
    // Exact counts of the integers (all of them, or those seen before an overflow), plus the
    // evenly thinned sample of the rest (all of a float stream) scaled to the voxels it stands for.
    std::uint64_t counted = 0;  // integer voxels counted exactly in the map (before any overflow)
    for (const auto& [value, count] : counts_) {
      s.histogram[bin_of(double(value))] += count;
      counted += count;
    }
    if (!seen_float_ && !distinct_overflow_) {
      s.distinct_values = counts_.size();
    } else {
      std::array<std::uint64_t, 16> sampled{};
      for (double v : samples_) ++sampled[bin_of(v)];
      const std::uint64_t sampled_voxels = finite_ - counted;
      const double scale = samples_.empty() ? 0 : double(sampled_voxels) / double(samples_.size());
      for (std::size_t b = 0; b < sampled.size(); ++b) s.histogram[b] += std::uint64_t(std::llround(sampled[b] * scale));
    }
  }
  return s;
}

VolumeStatistics compute_statistics(const Volume& v) {
  StatisticsAccumulator acc;
  acc.add(v);
  return acc.result();
}

}  // namespace strata
