#pragma once
/// @file
/// @brief Summary statistics of a volume (range, mean, spread, histogram, non-finite counts, distinct
/// labels), accumulated slab by slab: what `strata info` prints.
#include <array>
#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

#include "strata/core/volume.hpp"

namespace strata {

/// @brief Summary statistics of a volume, accumulated slab by slab (streaming). Float volumes may hold
/// NaN (masked or out-of-field voxels, as SPM, FSL and simulations write) and infinities: those
/// are counted apart, and everything else describes the finite values.
struct VolumeStatistics {
  std::uint64_t voxel_count = 0;
  std::uint64_t nan_count = 0, positive_infinity_count = 0, negative_infinity_count = 0;
  // Over the finite values; NaN when there are none (a volume of NaN only).
  double min = 0, max = 0, mean = 0, stddev = 0;
  // 16-bin histogram of the finite values over [min, max].
  std::array<std::uint64_t, 16> histogram{};
  std::uint64_t finite_count() const {
    return voxel_count - nan_count - positive_infinity_count - negative_infinity_count;
  }
  // Integer volumes only: distinct values (unset when more than the tracking cap) and the
  // fraction of voxels equal to 0 (the background of a label volume).
  std::optional<std::uint64_t> distinct_values;
  double zero_fraction = 0;
};

/// @brief Builds VolumeStatistics slab by slab: add() once per slab, then result().
class StatisticsAccumulator {
 public:
  // Distinct integer values are tracked up to this many; beyond it they are reported unknown.
  static constexpr std::size_t kDistinctCap = 1u << 22;
  // Values kept (evenly thinned) for the histogram when exact counts are not available.
  static constexpr std::size_t kSampleCap = 1u << 20;

  void add(const Volume& slab);
  VolumeStatistics result() const;

 private:
  template <class T> void add_typed(const T* v, std::int64_t n);
  void add_sample(double v);
  std::uint64_t n_ = 0, finite_ = 0, zeros_ = 0, nan_ = 0, positive_infinite_ = 0, negative_infinite_ = 0;
  double sum_ = 0, sum_sq_ = 0;
  double min_ = 0, max_ = 0;
  bool seen_float_ = false, distinct_overflow_ = false;
  std::vector<std::uint64_t> small_counts_;  // 8/16-bit: value + small_offset_ -> count
  std::int64_t small_offset_ = 0;
  std::unordered_map<std::int64_t, std::uint64_t> counts_;    // 32-bit integers
  std::vector<double> samples_;                               // floats / integers after the overflow
  std::uint64_t sample_stride_ = 1, sample_phase_ = 0;
};

/// @brief The statistics of one whole in-memory volume.
VolumeStatistics compute_statistics(const Volume& v);

}  // namespace strata
