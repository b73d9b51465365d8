#include "strata/core/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include "strata/core/error.hpp"

namespace strata {

namespace {

struct Partial {
  double sum_sq = 0, sum_err_sq = 0, max_err = 0;
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  std::uint64_t compared = 0, masked_matched = 0, masked_mismatched = 0;
};

template <class T, class U>
Partial accumulate(const T* a, const U* b, std::int64_t n) {
  Partial p;
  double sum_sq = 0, sum_err_sq = 0, max_err = 0, lo = p.lo, hi = p.hi;
  std::uint64_t matched = 0, mismatched = 0;
  constexpr bool may_be_non_finite = std::is_floating_point_v<T> || std::is_floating_point_v<U>;
#pragma omp parallel for reduction(+ : sum_sq, sum_err_sq, matched, mismatched) reduction(max : max_err, hi) \
    reduction(min : lo) schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const double x = double(a[i]), y = double(b[i]);
    if constexpr (may_be_non_finite) {
      if (!std::isfinite(x) || !std::isfinite(y)) {
        const bool same = !std::isfinite(x) && !std::isfinite(y) && (x == y || (std::isnan(x) && std::isnan(y)));
        matched += same;
        mismatched += !same;
        continue;
      }
    }
    const double e = x - y;
    sum_sq += x * x;
    sum_err_sq += e * e;
    max_err = std::max(max_err, std::abs(e));
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  return {sum_sq, sum_err_sq, max_err, lo, hi, std::uint64_t(n) - matched - mismatched, matched, mismatched};
}

}  // namespace

void ErrorAccumulator::add(const Volume& original, const Volume& approximation) {
  if (original.voxel_count() != approximation.voxel_count())
    throw Error("compare: volumes differ in size: " + original.dims().to_string() + " vs " +
                approximation.dims().to_string());
  Partial p = visit_dtype(original.dtype(), [&](auto ta) {
    using T = decltype(ta);
    return visit_dtype(approximation.dtype(), [&](auto tb) {
      using U = decltype(tb);
      return accumulate(original.samples<T>().data(), approximation.samples<U>().data(), original.voxel_count());
    });
  });
  add_partial(p.compared, p.sum_sq, p.sum_err_sq, p.max_err, p.lo, p.hi);
  masked_matched_ += p.masked_matched;
  masked_mismatched_ += p.masked_mismatched;
}

void ErrorAccumulator::add_partial(std::uint64_t n, double sum_sq, double sum_err_sq, double max_err, double lo,
                                   double hi) {
  if (n == 0) return;
  lo_ = n_ ? std::min(lo_, lo) : lo;
  hi_ = n_ ? std::max(hi_, hi) : hi;
  n_ += n;
  sum_sq_ += sum_sq;
  sum_err_sq_ += sum_err_sq;
  max_err_ = std::max(max_err_, max_err);
}

void ErrorAccumulator::merge(const ErrorAccumulator& o) {
  add_partial(o.n_, o.sum_sq_, o.sum_err_sq_, o.max_err_, o.lo_, o.hi_);
  masked_matched_ += o.masked_matched_;
  masked_mismatched_ += o.masked_mismatched_;
}

ErrorMetrics ErrorAccumulator::result() const {
  ErrorMetrics m;
  m.voxel_count = n_;
  m.masked_matched = masked_matched_;
  m.masked_mismatched = masked_mismatched_;
  if (n_ == 0) return m;
  const double inf = std::numeric_limits<double>::infinity();
  m.signal_rms = std::sqrt(sum_sq_ / double(n_));
  m.rmse = std::sqrt(sum_err_sq_ / double(n_));
  m.value_min = lo_;
  m.value_max = hi_;
  const double range = hi_ - lo_;
  m.snr_db = m.rmse > 0 ? 20.0 * std::log10(m.signal_rms / m.rmse) : inf;
  m.psnr_db = m.rmse > 0 ? (range > 0 ? 20.0 * std::log10(range / m.rmse) : -inf) : inf;
  m.nrmse = range > 0 ? m.rmse / range : (m.rmse > 0 ? inf : 0.0);
  m.max_abs_error = max_err_;
  return m;
}

ErrorMetrics compare_volumes(const Volume& original, const Volume& approximation) {
  if (!(original.dims() == approximation.dims()))
    throw Error("compare: dimensions differ: " + original.dims().to_string() + " vs " +
                approximation.dims().to_string());
  ErrorAccumulator acc;
  acc.add(original, approximation);
  return acc.result();
}

double bits_per_voxel(std::uint64_t bytes, std::uint64_t voxels) {
  return voxels ? 8.0 * double(bytes) / double(voxels) : 0.0;
}

}  // namespace strata
