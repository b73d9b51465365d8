#pragma once
/// @file
/// @brief The core step Δ of a PSNR or RMSE target, chosen before encoding from the spectrum of
/// level 0.
///
/// One uniform Δ in every brick is the rate–distortion-optimal split of a mean squared error
/// budget (equal slopes), but which Δ meets the budget depends on the data: on MRI and CT most
/// coefficients fall below the zero threshold and add less than Δ²/12, so Δ = √12 · RMSE lands
/// 4–7 dB above the target. The encoder's block-DCT basis is orthonormal and tiles each brick's
/// fitted region, so the squared error of quantizing the coefficients of level 0's blocks with
/// step Δ is the error of that basis at Δ: a histogram of the coefficient magnitudes, gathered in
/// the pre-pass, predicts the error of any Δ without encoding, and a bisection picks the largest
/// Δ that meets the budget. The compressor measures the real error afterwards and encodes again
/// with a smaller Δ if a prediction was short (ta/compress.cpp).
#include <array>
#include <cstdint>
#include <vector>

#include "strata/core/extent.hpp"

namespace strata::ta {

class StepCalibrator {
 public:
  /// @brief Scans a level of `dims` in blocks of `block` voxels per axis, aligned at the origin
  /// (as the brick cores tile it); the edge blocks repeat the edge voxels, as bricks do.
  StepCalibrator(const Extent& dims, int block);

  /// @brief The next slice (dims.x · dims.y samples, z order), kept until its block layer is full.
  void push_slice(std::vector<float> slice);
  /// @brief Transforms the last, partial layer of blocks. Call once after the last slice.
  void finish();

  /// @brief Predicted mean squared error per voxel of the scanned blocks when every coefficient
  /// is quantized with step Δ and codes below `zero_threshold` · Δ become zero.
  double predicted_mse(double step, double zero_threshold) const;
  /// @brief The largest Δ whose predicted mean squared error is at most `mse` (to 1/1000).
  double step_for_mse(double mse, double zero_threshold) const;

  std::uint64_t blocks() const { return blocks_; }

 private:
  struct Bin;
  struct Tally;
  void transform_layer();
  void add_block(const float* samples, Tally& tally) const;

  // Magnitude bins: the top 12 bits of a positive float below the sign (exponent and 4 mantissa
  // bits), i.e. 1/16-octave bins over every float.
  static constexpr int kBins = 1 << 12;
  struct Bin {
    std::uint64_t count = 0;
    double sum_abs = 0, sum_sq = 0;
  };
  // What one row of blocks adds: rows are transformed in parallel, each into its own tally,
  // and merged in row order, so the sums do not depend on the thread count.
  struct Tally {
    std::array<Bin, kBins> bins{};
    std::uint64_t blocks = 0;
  };

  static constexpr std::int64_t kDenseBlocks = 8192;  // levels with more blocks are sampled

  Extent dims_;
  int block_;
  std::vector<float> basis_;                 // block x block, row = sample, column = frequency
  std::vector<std::vector<float>> layer_;    // up to `block` slices of the current block layer
  std::array<Bin, kBins> bins_{};
  std::uint64_t blocks_ = 0;
  std::vector<Tally> row_tallies_;  // one per block row of the current layer, reused
  std::int64_t slices_seen_ = 0;
  bool sparse_ = false;
};

}  // namespace strata::ta
