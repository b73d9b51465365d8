#include "strata/mixture/query_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "strata/core/error.hpp"

namespace strata::mixture {

namespace {

// Float rounding of a sum of sample weights, not an estimation error.
bool within_rounding(double error, double exact) { return error <= 1e-9 * std::max(1.0, exact); }

}  // namespace

void QueryCalibration::add(const BoxHistogram& estimate, const BoxHistogram& exact) {
  if (!(estimate.box == exact.box)) throw Error("query calibration: estimate and exact histograms are of different boxes");
  ++boxes;
  auto score = [&](std::uint32_t source, double value, double sigma, double truth) {
    const double error = std::abs(value - truth);
    abs_error_sum += error;
    ++pairs;
    double z = 0.0;
    if (!within_rounding(error, truth)) z = sigma > 0.0 ? error / sigma : std::numeric_limits<double>::infinity();
    for (int k = 1; k <= 6; ++k) outside[std::size_t(k - 1)] += z > double(k) ? 1 : 0;
    if (z > worst_z) {
      worst_z = z;
      worst_box = exact.box;
      worst_source = source;
      worst_estimate = value;
      worst_sigma = sigma;
      worst_exact = truth;
    }
  };
  const auto& e = estimate.counts;
  const auto& x = exact.counts;
  std::size_t i = 0, j = 0;  // both ascend by source
  while (i < e.size() || j < x.size()) {
    if (j == x.size() || (i < e.size() && e[i].source < x[j].source)) {
      score(e[i].source, e[i].count, e[i].sigma, 0.0);
      ++i;
    } else if (i == e.size() || x[j].source < e[i].source) {
      score(x[j].source, 0.0, 0.0, x[j].count);
      ++j;
    } else {
      score(e[i].source, e[i].count, e[i].sigma, x[j].count);
      ++i, ++j;
    }
  }
}

double QueryCalibration::share_outside(int k) const {
  if (k < 1 || k > 6) throw Error("query calibration: k must be 1..6, got " + std::to_string(k));
  return pairs ? double(outside[std::size_t(k - 1)]) / double(pairs) : 0.0;
}

QueryCalibration calibrate(const BoxQuery& query, std::span<const std::int64_t> sizes, int boxes_per_size,
                           std::uint64_t seed, const QueryOptions& options) {
  if (boxes_per_size < 1) throw Error("query calibration: at least one box per size, got " + std::to_string(boxes_per_size));
  const Extent d = query.grid().level_dims(0);
  std::mt19937_64 rng(seed);
  auto start = [&](std::int64_t dim, std::int64_t size) {
    return std::uniform_int_distribution<std::int64_t>(0, dim - size)(rng);
  };
  QueryCalibration c;
  for (std::int64_t size : sizes) {
    if (size < 1) throw Error("query calibration: box sizes must be >= 1, got " + std::to_string(size));
    const Extent s{std::min(size, d.x), std::min(size, d.y), std::min(size, d.z)};
    for (int b = 0; b < boxes_per_size; ++b) {
      const Extent lo{start(d.x, s.x), start(d.y, s.y), start(d.z, s.z)};
      const Box box{lo, {lo.x + s.x, lo.y + s.y, lo.z + s.z}};
      c.add(query.run(box, options), query.naive(box));
    }
  }
  return c;
}

}  // namespace strata::mixture
