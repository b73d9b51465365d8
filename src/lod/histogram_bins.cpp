#include "strata/lod/histogram_bins.hpp"

#include <cmath>

namespace strata::lod {

std::uint64_t visible_bins_where(double lo, double hi, const std::function<bool(double, double)>& visible) {
  std::uint64_t mask = 0;
  const double width = (hi - lo) / kHistogramBins;
  for (int i = 0; i < kHistogramBins; ++i)
    if (visible(lo + i * width, lo + (i + 1) * width)) mask |= std::uint64_t(1) << i;
  return mask;
}

bool brick_visible(const store::BrickEntry& entry, std::uint64_t visible_bins, double lo, double hi) {
  // A constant NaN or infinite brick (outside a field of view) is empty space.
  if (entry.kind == store::PayloadKind::constant)
    return std::isfinite(entry.min) && ((visible_bins >> histogram_bin(entry.min, lo, hi)) & 1u);
  return (entry.histogram & visible_bins) != 0;
}

}  // namespace strata::lod
