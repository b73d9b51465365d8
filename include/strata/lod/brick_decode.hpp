#pragma once
/// @file
/// @brief ta::decode_brick split in two, so the loader can keep the middle product: (1) the payload
/// (inflated when zstd-packed) dequantized at its full stored rank, (2) the reconstruction at
/// leading ranks K. Reconstructing the leading block of a full-rank model feeds the kernel the
/// same floats as decoding at rank K directly, so the samples are identical.
#include <cstddef>
#include <span>
#include <string>

#include "strata/lod/model_cache.hpp"
#include "strata/ta/ta_volume.hpp"
#include "strata/tensor/reconstruct.hpp"

namespace strata::lod {

/// @brief Dequantizes a Tucker payload at its stored rank; `context` prefixes error messages; a
/// global_core payload takes the brick's global `bases` as its factors. Throws Error for
/// constant bricks and bricks not B wide.
BrickModel dequantize_payload(store::PayloadKind kind, std::span<const std::byte> payload,
                              const quant::QuantScheme& scheme, int brick_width, ta::DecodeScratch& scratch,
                              const std::string& context, const ta::BrickBases* bases = nullptr);

/// @brief Reads (with checksum) and dequantizes one brick of `volume`; adds the payload size to
/// `bytes_read`.
BrickModel fetch_model(const ta::TaVolume& volume, const store::BrickEntry& entry, ta::DecodeScratch& scratch,
                       std::uint64_t& bytes_read);

/// @brief B^3 floats of the model truncated to ranks min(K, R_n) (K clamped to >= 1) into `out`.
void reconstruct_at_rank(const quant::DequantizedModel& model, int k, tensor::BrickReconstructor& reconstructor,
                         std::span<float> out);

/// @brief "file: brick (level l, x,y,z)" for error messages.
std::string brick_context(const ta::TaVolume& volume, const store::BrickKey& key);

}  // namespace strata::lod
