#pragma once
/// @brief How honest the sigmas of box histogram queries are, measured against exact counts.
///
/// Every (label, box) pair present in an estimated histogram or in the exact one (a label the
/// estimate misses counts with estimate 0) is scored by z = |estimate - exact| / sigma. For
/// well-calibrated Gaussian errors about 31.7% of pairs lie outside 1 sigma, 4.6% outside 2 and
/// 0.27% outside 3. Errors within floating-point rounding (1e-9 of the count) count as 0, so
/// exact answers with sigma 0 score 0; any larger error with sigma 0 scores +infinity.
#include <array>
#include <cstdint>
#include <span>

#include "strata/mixture/box_query.hpp"

namespace strata::mixture {

struct QueryCalibration {
  std::uint64_t boxes = 0;
  std::uint64_t pairs = 0;
  std::array<std::uint64_t, 6> outside{};  // outside[k - 1]: pairs with z > k
  double worst_z = 0.0;                    // the pair with the largest z:
  Box worst_box;
  std::uint32_t worst_source = 0;
  double worst_estimate = 0.0, worst_sigma = 0.0, worst_exact = 0.0;
  double abs_error_sum = 0.0;  // sum over pairs of |estimate - exact|

  /// Scores the pairs of one box (estimate and exact must be of the same box).
  void add(const BoxHistogram& estimate, const BoxHistogram& exact);
  /// Share of pairs outside k sigma, k = 1..6 (0 when there are no pairs).
  double share_outside(int k) const;
};

/// `boxes_per_size` boxes of each edge length in `sizes` (clamped to the volume per axis) at
/// uniformly random positions from `seed`, each estimated with `options` and counted exactly
/// (naive level-0 scan).
QueryCalibration calibrate(const BoxQuery& query, std::span<const std::int64_t> sizes, int boxes_per_size,
                           std::uint64_t seed, const QueryOptions& options = {});

}  // namespace strata::mixture
