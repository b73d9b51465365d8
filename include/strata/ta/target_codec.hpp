#pragma once
/// @file
/// @brief The error-target brick encoder: a brick coded to an error budget instead of a fixed rank.
///
/// Per brick (paper 1 §7 names adaptive ranks and better coefficient coding as its next steps):
///  1. the brick mean becomes the offset; a brick its offset already represents within the
///     target becomes a constant brick (no payload);
///  2. a block-DCT basis and a full HOSVD of the rest, the smaller payload kept; every core coefficient is quantized with one uniform step Δ (the
///     same in every brick of a level: equal slopes, the rate–distortion-optimal split of a mean
///     squared error budget across bricks), and each mode keeps the leading slices that still
///     hold a non-zero code: empty, smooth and busy bricks get the ranks they need;
///  3. column r of U^(n) is quantized with step Δ / σ_r (σ_r its singular value), so each factor
///     entry adds about as much error as a core coefficient; the core is then re-fitted to the
///     quantized factors (least squares) and quantized;
///  4. a PSNR/RMSE budget is global: Δ is calibrated for the whole level (ta/step_calibration.hpp)
///     and coefficients below 0.65 Δ are dropped (a dead zone); only in the capped fallback does a
///     brick whose mean squared error exceeds its cap shrink Δ and get coded again;
///  5. with a max-error target, voxels the model misses by more than the bound (thin bright
///     structures) get a sparse correction, quantized so every voxel ends within the bound;
///  6. the coded payload (quant/coded_brick.hpp) is kept only when smaller than the brick stored
///     losslessly (payload kind raw_zstd).
/// Results depend only on the brick and the target: the same on any thread count.
#include <array>
#include <limits>
#include <span>
#include <vector>

#include "strata/ta/brick_codec.hpp"
#include "strata/tensor/tensor3.hpp"

namespace strata::ta {

/// @brief The metadata "quant" of an error-target file: its bricks carry their own steps.
inline constexpr const char* kCodedQuantName = "coded";

/// @brief What one brick must hold (one per octree level, from the user's ErrorTarget).
struct BrickTarget {
  double core_step = 1;                                            // Δ of the core codes
  double mse_cap = std::numeric_limits<double>::infinity();        // over the brick's core voxels
  double max_error = std::numeric_limits<double>::infinity();      // on every voxel of the brick
  double zero_threshold = 0.5;                                     // codes below it (in steps) are 0
  bool try_hosvd = true;  // false: the block-DCT basis alone where it meets the target (the HOSVD is most of the time)
  int max_rank = 256;                                              // per mode
  int zstd_level = 3;                                              // of the lossless fallback
};

/// @brief Throws ParameterError("ErrorTarget::value") unless the value is finite and positive (a
/// PSNR at most 300 dB), and ParameterError("ErrorTarget::coarse_growth") unless it is >= 1.
void check_target(const ErrorTarget& target);

/// @brief Level 0's absolute root mean squared error for an rmse or psnr target over a volume
/// whose values span [lo, hi] (0 for the other kinds).
double target_rmse(const ErrorTarget& target, double lo, double hi);

/// @brief The brick target of each of `level_count` levels: level 0 holds the user's target,
/// level l growth^l times it. For an rmse or psnr target, `level0_step` > 0 is level 0's
/// calibrated Δ (ta/step_calibration.hpp): the levels use growth^l times it and no per-brick cap
/// (the budget is global; the caller checks it). With `level0_step` = 0 every brick is capped at
/// the level's mean squared error (Δ = √12 · RMSE, shrunk per brick until the cap holds, else
/// stored losslessly): the guaranteed fallback.
std::vector<BrickTarget> level_targets(const ErrorTarget& target, double lo, double hi, int level_count, int max_rank,
                                       int zstd_level, double level0_step = 0);

/// @brief The block of the block-DCT basis for a fitted width: the divisor of `fitted` nearest 8
/// within [4, 16], or 0 when there is none.
int dct_block_width(std::int64_t fitted);

/// @brief The dead zone of rmse and psnr targets: codes below it (in steps) are zero.
inline constexpr double kMseZeroThreshold = 0.65;

/// @brief The brick-local voxels [lo, hi) the level takes from this brick (its core, clipped to
/// the level); the mean squared error is capped over these.
struct CoreRegion {
  std::array<int, 3> lo{0, 0, 0}, hi{0, 0, 0};
  // The model is fitted on [margin, B - margin)^3 (the unclipped core: the brick overlap); the
  // overlap voxels get a least-squares continuation of it, so shared voxels are not paid twice.
  int margin = 0;
};

/// @brief The squared and largest error of `decoded` against `samples` (both `dims`, first index
/// fastest) over the core voxels.
struct CoreError {
  double squared = 0, max_abs = 0;
  std::int64_t voxels = 0;
  double mse() const { return voxels ? squared / double(voxels) : 0; }
};
CoreError core_error(std::span<const float> samples, std::span<const float> decoded, const tensor::Dims3& dims,
                     const CoreRegion& core);

/// @brief Encodes `samples` (B^3, first index fastest) to `target`; writes the samples a decoder
/// reconstructs at full rank into `decoded` (B^3 floats). Throws Error for non-finite samples.
EncodedBrick encode_brick_to_target(const tensor::Tensor3& samples, const CoreRegion& core, const BrickTarget& target,
                                    std::span<float> decoded);

}  // namespace strata::ta
