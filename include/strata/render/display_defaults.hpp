#pragma once
/// @file
/// @brief How a dataset first appears: its transfer-function preset and slice window, chosen
/// from the data (value histogram, value range, the file's name) instead of one fixed preset.
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace strata::render {

/// @brief Bins of the value histogram sources report (RenderSession::describe derives the
/// viewer's 64-bin histogram and the percentile window from it).
inline constexpr int kValueHistogramBins = 1024;

/// @brief The bin of `v` among `bins` equal bins over [lo, hi] (the last bin holds hi; a
/// degenerate range puts everything in bin 0). `v` must be finite.
int value_bin(double v, double lo, double hi, int bins);

/// @brief Counts in `bins` equal bins over [lo, hi] of the finite samples (NaN and infinite
/// samples are empty space, not values).
std::vector<std::uint64_t> value_histogram(std::span<const float> samples, double lo, double hi,
                                           int bins = kValueHistogramBins);

/// @brief Sums groups of counts.size() / bins neighbouring counts (counts.size() a multiple of
/// bins); no counts (a label source's) give none.
std::vector<std::uint64_t> coarser_histogram(std::span<const std::uint64_t> counts, int bins);

/// @brief The values below which `fraction` and above which `fraction` of the counted samples
/// lie (linear inside a bin), as radiology viewers' automatic window does with 0.5%: a few
/// outliers (metal in a CT, hot pixels) no longer squeeze the tissue into a few grey levels.
/// [lo, hi] for no counts or a window narrower than one bin.
std::pair<double, double> percentile_window(std::span<const std::uint64_t> counts, double lo, double hi,
                                            double fraction = 0.005);

/// @brief The transfer-function preset a dataset opens with: "ct" for values in Hounsfield
/// units (below -500 and above 500) or a name that says CT; "mri" for a name that says MR
/// (mri, mr, t1, t2, flair, dwi, bold), a NIfTI file (MR's usual container) or a volume placed
/// in an anatomical space (`anatomical`: RAS or LPS, which a compressed file keeps when its
/// name no longer says); otherwise "grayscale" (electron microscopy, density and simulation
/// fields).
std::string default_preset(const std::string& file_name, double lo, double hi, bool anatomical = false);

/// @brief `window` widened to whole numbers for integer samples (a window edge between two
/// sample values means nothing, and reads badly: 0.0013 instead of 0).
std::pair<double, double> whole_window(std::pair<double, double> window, bool integer_samples);

}  // namespace strata::render
