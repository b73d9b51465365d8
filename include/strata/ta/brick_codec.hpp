#pragma once
/// @file
/// @brief One brick <-> one payload: a quantized Tucker model, or a single value for constant bricks.
///
/// Implements the brick codec of paper 1 §4: a rank-reduced Tucker decomposition (truncated
/// HOSVD refined by HOOI sweeps), the tensor-specific quantization of core and factors, and an
/// optional lossless zstd stage (payload kind tucker_zstd). Byte layouts: docs/format.md
/// ("Tucker brick payload"); effect of the defaults:
/// docs/benchmarks.md#codec-defaults-hooi-sweeps-and-the-zstd-stage.
///
/// Thread safety: the functions keep no shared state. They may run concurrently as long as each
/// thread passes its own DecodeScratch, BrickReconstructor and output buffers.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "strata/quant/brick.hpp"
#include "strata/quant/scheme.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/codec_names.hpp"
#include "strata/tensor/reconstruct.hpp"
#include "strata/tensor/tensor3.hpp"

namespace strata::ta {

/// @brief A quality target for the error-target codec (ta/target_codec.hpp), instead of a rank.
enum class TargetKind : std::uint8_t {
  none,       // fixed-rank mode: CodecParams::rank and ::quant decide
  psnr,       // dB over the volume's value range, at level 0 (the whole volume's mean squared error)
  rmse,       // absolute root mean squared error at level 0
  max_error,  // absolute bound on every sample of level 0
};
const char* target_kind_name(TargetKind kind);

struct ErrorTarget {
  TargetKind kind = TargetKind::none;
  double value = 0;
  // Level l is coded to growth^l times level 0's error: coarse levels are seen at one voxel per
  // pixel and hold averages, so they need less precision (>= 1).
  double coarse_growth = 2.0;
};

/// @brief Encoder settings (the `compress` options --rank, --quant, --hooi, --zstd and the targets).
struct CodecParams {
  int rank = 16;                 // R: stored rank per mode, in [1, brick width]; with a target, the cap
  quant::QuantScheme quant;      // how cores and factors are stored
  int hooi_iterations = 1;       // most HOOI sweeps after the truncated HOSVD; 0 = HOSVD only
  double hooi_tolerance = 1e-4;  // HOOI stops when the fit changes by less than this per sweep
  // Lossless zstd stage over each quantized brick (0 = off); kept only where it makes the
  // payload smaller.
  int zstd_level = 3;
  ErrorTarget target;  // kind none: fixed-rank mode
  // Fixed-rank mode: a brick whose Tucker payload is larger than its samples stored losslessly
  // (raw_packed: thin volumes, whose bricks are mostly repeated edge, and noise) is stored so.
  // Such a brick shows every detail at every rank; false keeps every brick Tucker, for studies
  // of the Tucker codec itself, and so does zstd_level 0 (the plain fixed layout throughout).
  // The error-target modes always fall back.
  bool lossless_fallback = true;
};

/// @brief One encoded brick: payload kind and bytes, constant value, size breakdown.
struct EncodedBrick {
  store::PayloadKind kind = store::PayloadKind::constant;
  std::vector<std::byte> payload;
  float constant_value = 0;  // for constant bricks
  // Sizes of the payload's parts, for `strata eval` (bytes).
  std::size_t core_bytes = 0, factor_bytes = 0, header_bytes = 0;
  // Error-target mode, when both bases were coded: each one's payload size (else 0).
  std::size_t block_dct_bytes = 0, hosvd_bytes = 0;
};

/// @brief The row-block bases of one brick of the global-basis codec (ta-global, paper 2), for
/// modes 1, 2, 3: B × R_n floats each, orthonormal columns (ta/global_basis.hpp).
using BrickBases = std::array<const tensor::Matrix<float>*, 3>;

/// @brief Encodes a brick of the global-basis codec: a constant brick when all samples are
/// equal, else its core (the samples projected on `bases`) quantized with `scheme` as a
/// core-only brick (kind global_core), zstd-compressed at `zstd_level` (kind global_core_zstd)
/// when that is smaller (0 = never). `core` receives the dequantized core (what decoders see),
/// empty for a constant brick. Throws Error for non-finite samples.
EncodedBrick encode_global_brick(const tensor::Tensor3& samples, const BrickBases& bases, const quant::QuantScheme& scheme,
                                 int zstd_level, tensor::Tensor3& core);

/// @brief Encodes a brick of samples (B x B x B, first index fastest).
/// A brick whose samples are all equal becomes a constant brick (no payload). Otherwise returns
/// a tucker payload, or tucker_zstd when params.zstd_level > 0 and compression makes it
/// smaller, or (params.lossless_fallback) the lossless raw_packed brick when that is smaller
/// still. Throws Error when params.rank is not in [1, B], params.quant is inconsistent, the
/// decomposition fails or the model holds non-finite values (quantization rejects them).
EncodedBrick encode_brick(const tensor::Tensor3& samples, const CodecParams& params);

/// @brief `coded`, or the lossless raw_packed brick of `samples` (`width`^3) when that is
/// smaller: no brick costs more than storing its samples losslessly.
EncodedBrick lossless_if_smaller(EncodedBrick coded, std::span<const float> samples, int width, int zstd_level);
/// @brief The lossless raw_packed brick of `samples` (`width`^3), whatever its size.
EncodedBrick lossless_brick(std::span<const float> samples, int width, int zstd_level);

/// @brief Buffers reused across decodes, one per thread.
struct DecodeScratch {
  quant::DequantizedModel model;
  std::vector<std::byte> inflated, unshuffled;  // tucker_zstd payloads, reused across bricks
};

/// @brief The plain quantized-brick bytes of a tucker or tucker_zstd payload.
/// For tucker returns `payload` itself; for tucker_zstd inflates into `scratch` and returns a
/// view of it, valid until `scratch` is used again. Throws Error for any other kind (or, with
/// 16-bit factors, inflated bytes that are not a quantized brick of `scheme`), and
/// FormatError(context, "zstd payload", ...) when the zstd frame is corrupt or inflates to more
/// than 64 MiB.
std::span<const std::byte> plain_payload(store::PayloadKind kind, std::span<const std::byte> payload,
                                         const quant::QuantScheme& scheme, DecodeScratch& scratch,
                                         const std::string& context);

/// @brief The shared front of decode_brick and the LOD loader (lod::dequantize_payload).
/// Takes the plain bytes of a tucker or tucker_zstd payload, checks that the brick is
/// `brick_width` wide along every axis and dequantizes it at the leading ranks min(rank, R_n)
/// into `model` (a rank of at least the stored one keeps the full stored rank). Throws Error
/// prefixed with `context` for a malformed payload, a wrong width or rank < 1.
/// A global_core payload (inside a masked one too) needs the brick's `bases`, which become the
/// model's factors; other kinds ignore them.
void dequantize_brick(store::PayloadKind kind, std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                      int brick_width, int rank, DecodeScratch& scratch, quant::DequantizedModel& model,
                      const std::string& context, const BrickBases* bases = nullptr);

/// @brief The leading ranks min(K, R_n) (K clamped to >= 1) at which `model` is reconstructed
/// for rank K.
tensor::Ranks3 leading_ranks(const quant::DequantizedModel& model, int k);

/// @brief `out` (B^3 floats) = the model at `leading` ranks plus its offset; the sparse
/// correction of a coded brick is added when `leading` are its full ranks (the max-error
/// guarantee holds there); a losslessly stored brick is copied. Every decoder goes through here.
void reconstruct_model(const quant::DequantizedModel& model, const tensor::Ranks3& leading,
                       tensor::BrickReconstructor& reconstructor, std::span<float> out);

/// @brief A tucker payload's size split into header, core and factor bytes (for `strata eval`).
struct PayloadParts {
  std::size_t header_bytes = 0, core_bytes = 0, factor_bytes = 0;
};
/// @brief The parts of `payload`, the plain (inflated) quantized brick. Throws Error prefixed
/// with `context` when it is not a valid quantized brick of `scheme`.
PayloadParts payload_parts(std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                           const std::string& context);

/// @brief Decodes a payload at reconstruction rank K (1 <= K <= stored rank; larger K is
/// clamped) into `out` (B^3 floats). Constant bricks fill `out` with their value. Reuses the
/// scratch of `reconstructor` and `scratch` so a loop over bricks does not allocate. Throws
/// Error prefixed with `context` when `out` does not hold B^3 floats, K < 1 or the payload is
/// malformed.
void decode_brick(store::PayloadKind kind, std::span<const std::byte> payload, float constant_value,
                  const quant::QuantScheme& scheme, int brick_width, int rank, tensor::BrickReconstructor& reconstructor,
                  DecodeScratch& scratch, std::span<float> out, const std::string& context,
                  const BrickBases* bases = nullptr);

}  // namespace strata::ta
