#pragma once
// NaN and infinite samples in a scalar volume (SPM/FSL write NaN outside the field of view,
// simulations mark masked cells with it). The codecs see finite data only: the encoder takes the
// non-finite voxels out of a brick, fills them with a stand-in the models code cheaply, codes the
// brick as usual and wraps its payload with a mask (payload kind `masked`, docs/format.md); every
// decoder writes the mask's values back after the reconstruction (reconstruct_model). Private to
// src/ta.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "strata/store/container.hpp"
#include "strata/ta/brick_codec.hpp"
#include "strata/ta/target_codec.hpp"

namespace strata::ta {

/// @brief The non-finite voxels of a brick: ascending indices (first index fastest) and the value
/// each holds (NaN, +inf or -inf; a NaN decodes as the quiet NaN, whatever its payload bits were).
struct NonFiniteMask {
  std::vector<std::uint32_t> index;
  std::vector<float> value;
  bool empty() const { return index.empty(); }
};

/// @brief Whether any of `samples` is NaN or infinite (one vectorised pass, no early exit).
bool has_non_finite(std::span<const float> samples);

/// @brief Takes the non-finite samples out of `samples` (a brick of `dims`, first index fastest):
/// each is replaced by a pull-push fill from the finite ones nearby (0 when there are none), a
/// stand-in that continues the data so the codecs pay little for it; returns where they were and
/// what they held.
NonFiniteMask take_non_finite(std::span<float> samples, const tensor::Dims3& dims);

/// @brief Writes the mask's values back into `out` (a decoded brick of the mask's size).
void restore_non_finite(const NonFiniteMask& mask, std::span<float> out);

/// @brief to[i] = from[i] at the mask's voxels (the encoder gives its decoded brick the samples'
/// stand-ins there, so errors and statistics see the finite voxels only).
void copy_masked(const NonFiniteMask& mask, std::span<const float> from, std::span<float> to);

/// @brief How many of the mask's voxels lie in the core region `core` of a brick of `dims`.
std::int64_t masked_in_core(const NonFiniteMask& mask, const tensor::Dims3& dims, const CoreRegion& core);

/// @brief Turns `brick` (any brick kind) into a `masked` brick of `voxels` around it.
void wrap_with_mask(const NonFiniteMask& mask, std::size_t voxels, int zstd_level, EncodedBrick& brick);

/// @brief True when every voxel of a brick of `voxels` is in the mask with one and the same value
/// (all NaN, all +inf or all -inf): such a brick is stored as a constant.
bool uniform_non_finite(const NonFiniteMask& mask, std::size_t voxels);

/// @brief The payload of kind `masked`: the inner brick's kind and payload (an inner constant
/// carries its value), and the mask as one zstd frame of a class byte per voxel.
std::vector<std::byte> wrap_masked(const NonFiniteMask& mask, std::size_t voxels, store::PayloadKind inner,
                                   float inner_constant, std::span<const std::byte> inner_payload, int zstd_level);

struct MaskedPayload {
  store::PayloadKind inner = store::PayloadKind::constant;
  float inner_constant = 0;
  std::span<const std::byte> inner_payload;  // a view into the wrapped bytes
  NonFiniteMask mask;
};

/// @brief Reads a `masked` payload of a brick of `voxels`. Throws FormatError(context, field, …)
/// for a truncated payload, an inner kind that is not a brick kind (or is `masked` again), a mask
/// frame of the wrong size or a class byte above 3.
MaskedPayload unwrap_masked(std::span<const std::byte> bytes, std::size_t voxels, std::vector<std::byte>& scratch,
                            const std::string& context);

}  // namespace strata::ta
