#pragma once
/// @file
/// @brief Transfer-function culling with the 64-bit brick histograms of the index (paper 1, §3): bit i
/// of an entry's histogram is set when some voxel of the brick falls into bin i of 64 equal bins
/// over the volume's value range. A caller turns its transfer function into the mask of bins
/// where opacity is non-zero; a brick whose histogram misses that mask is invisible.
#include <cstdint>
#include <functional>

#include "strata/store/brick_histogram.hpp"
#include "strata/store/container.hpp"

namespace strata::lod {

using store::kHistogramBins;

/// @brief The bin of `value` exactly as the compressor assigns it (store::HistogramBinning).
inline int histogram_bin(double value, double lo, double hi) { return store::HistogramBinning(lo, hi).bin(value); }

/// @brief Mask of the bins for which `visible(bin_lo, bin_hi)` is true, bin i spanning
/// [lo + i (hi - lo) / 64, lo + (i + 1) (hi - lo) / 64].
std::uint64_t visible_bins_where(double lo, double hi, const std::function<bool(double, double)>& visible);

/// @brief False when no voxel of the brick can be visible under `visible_bins`. Constant bricks are
/// tested with the bin of their value, so they never depend on how the histogram was filled.
bool brick_visible(const store::BrickEntry& entry, std::uint64_t visible_bins, double lo, double hi);

}  // namespace strata::lod
