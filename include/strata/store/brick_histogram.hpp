#pragma once
/// @brief The binning rule of a brick's 64-bit histogram (`BrickEntry::histogram`, docs/format.md):
/// bin i of 64 equal bins over the volume's value range [lo, hi] (metadata
/// "source.value_range"). The file format defines it, so writers (the compressor's brick
/// statistics, including its vectorised kernels) and readers (transfer-function culling) share
/// this one definition: bin = trunc((v - lo) · 64 / (hi - lo)), values below lo and NaN in bin 0,
/// values from the last bin's start up in bin 63, and every value in bin 0 when hi <= lo.
#include <cstdint>

namespace strata::store {

inline constexpr int kHistogramBins = 64;

struct HistogramBinning {
  double lo = 0.0;
  double scale = 0.0;  // bins per unit value; 0 for a degenerate range

  HistogramBinning(double range_lo, double range_hi)
      : lo(range_lo), scale(range_hi > range_lo ? double(kHistogramBins) / (range_hi - range_lo) : 0.0) {}

  /// The bin of `value`, in [0, 63].
  int bin(double value) const {
    const double x = (value - lo) * scale;
    return !(x >= 0) ? 0 : x < kHistogramBins - 1 ? int(x) : kHistogramBins - 1;
  }
};

}  // namespace strata::store
