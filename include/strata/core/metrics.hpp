#pragma once
/// @file
/// @brief Error metrics of an approximation against its original (SNR, PSNR, normalized RMSE, max
/// error), accumulated slab by slab, and bits per voxel.
#include <cstdint>
#include <span>

#include "strata/core/volume.hpp"

namespace strata {

/// @brief Reconstruction quality, as defined in paper 1 (Suter et al. 2011, §6.2.2):
///   signal = averaged Frobenius norm sqrt(1/N sum a^2), rmse = sqrt(1/N sum (a - ã)^2),
///   SNR = 20 log10(signal / rmse). We also report PSNR over the original's value range,
///   normalized RMSE (rmse / range) and the maximum absolute error.
///
/// Voxels that are not finite (NaN: masked or out of the field of view; infinities) are left out
/// of every figure: `voxel_count` counts the voxels finite in both volumes. A voxel non-finite in
/// both with the same value (NaN and NaN, or the same infinity) is `masked_matched`; one that is
/// non-finite in only one volume, or non-finite in both with different values, is
/// `masked_mismatched`: a decoder that loses or invents NaN shows there.
struct ErrorMetrics {
  std::uint64_t voxel_count = 0;
  std::uint64_t masked_matched = 0, masked_mismatched = 0;
  double signal_rms = 0;   // ‖A‖F̄
  double rmse = 0;
  double snr_db = 0;       // +inf when rmse == 0
  double psnr_db = 0;      // 20 log10(range / rmse); +inf when rmse == 0
  double nrmse = 0;        // rmse / range (0 when range == 0)
  double max_abs_error = 0;
  double value_min = 0, value_max = 0;  // of the original
};

/// @brief Accumulates sums over slabs so volumes larger than memory can be compared piece by piece.
/// Each add() sums its slab in doubles, then adds the partial sums (limits rounding growth).
class ErrorAccumulator {
 public:
  /// @brief Same voxel count required; any pair of dtypes (e.g. u8 original, f32 reconstruction).
  void add(const Volume& original, const Volume& approximation);
  void merge(const ErrorAccumulator& other);
  ErrorMetrics result() const;

 private:
  void add_partial(std::uint64_t n, double sum_sq, double sum_err_sq, double max_err, double lo, double hi);
  std::uint64_t n_ = 0, masked_matched_ = 0, masked_mismatched_ = 0;
  double sum_sq_ = 0, sum_err_sq_ = 0, max_err_ = 0;
  double lo_ = 0, hi_ = 0;
};

/// @brief The metrics of two whole volumes of the same dims (throws Error when they differ).
ErrorMetrics compare_volumes(const Volume& original, const Volume& approximation);

/// @brief Bits per voxel of a stored representation: 8 * bytes / voxels (0 when there are no voxels).
double bits_per_voxel(std::uint64_t bytes, std::uint64_t voxels);

}  // namespace strata
