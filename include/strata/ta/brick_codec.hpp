#pragma once
// One brick <-> one payload: rank-reduced Tucker decomposition (HOOI) plus the tensor-specific
// quantization of paper 1 §4, or a single value for constant bricks.
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "strata/quant/brick.hpp"
#include "strata/quant/scheme.hpp"
#include "strata/store/container.hpp"
#include "strata/tensor/reconstruct.hpp"
#include "strata/tensor/tensor3.hpp"

namespace strata::ta {

struct CodecParams {
  int rank = 16;                 // R: stored rank per mode (<= brick width)
  quant::QuantScheme quant;      // how cores and factors are stored
  int hooi_iterations = 1;       // HOOI sweeps after HOSVD; 0 = HOSVD only (one sweep gets
                                 // all of the gain on ch2better: 25.90 -> 26.00 dB)
  double hooi_tolerance = 1e-4;
  // Lossless zstd stage over each quantized brick (0 = off). Decoding a 7 KB brick costs a few
  // microseconds next to its reconstruction, and saves 10-20% of the file.
  int zstd_level = 3;
};

struct EncodedBrick {
  store::PayloadKind kind = store::PayloadKind::constant;
  std::vector<std::byte> payload;
  float constant_value = 0;  // for constant bricks
  // Sizes of the payload's parts, for `strata eval` (bytes).
  std::size_t core_bytes = 0, factor_bytes = 0, header_bytes = 0;
};

// Encodes a brick of samples (B x B x B, first index fastest).
EncodedBrick encode_brick(const Tensor3& samples, const CodecParams& params);

// Buffers reused across decodes, one per thread.
struct DecodeScratch {
  quant::DequantizedModel model;
  std::vector<std::byte> inflated, unshuffled;  // tucker_zstd payloads, reused across bricks
};

// The plain quantized-brick bytes of a tucker or tucker_zstd payload (inflated into `scratch`).
std::span<const std::byte> plain_payload(store::PayloadKind kind, std::span<const std::byte> payload,
                                         const quant::QuantScheme& scheme, DecodeScratch& scratch,
                                         const std::string& context);

// The shared front of decode_brick and the LOD loader (lod::dequantize_payload): the plain
// bytes of a tucker or tucker_zstd payload, checked to be `brick_width` wide along every axis
// and dequantized at the leading ranks min(rank, R_n) into `model` (a rank of at least the
// stored one keeps the full stored rank). Throws Error prefixed with `context`.
void dequantize_brick(store::PayloadKind kind, std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                      int brick_width, int rank, DecodeScratch& scratch, quant::DequantizedModel& model,
                      const std::string& context);

// Splits a tucker payload's size into header, core and factor bytes (for `strata eval`).
struct PayloadParts {
  std::size_t header_bytes = 0, core_bytes = 0, factor_bytes = 0;
};
// `payload` is the plain (inflated) quantized brick.
PayloadParts payload_parts(std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                           const std::string& context);

// Decodes a payload at reconstruction rank K (1 <= K <= stored rank; larger K is clamped)
// into `out` (B^3 floats). Constant bricks fill `out` with their value. Reuses the scratch of
// `reconstructor` and `scratch` so a loop over bricks does not allocate.
void decode_brick(store::PayloadKind kind, std::span<const std::byte> payload, float constant_value,
                  const quant::QuantScheme& scheme, int brick_width, int rank, BrickReconstructor& reconstructor,
                  DecodeScratch& scratch, std::span<float> out, const std::string& context);

}  // namespace strata::ta
