#pragma once
/// @file
/// @brief The entropy-coded Tucker brick of the error-target codec (payload kind tucker_coded):
/// integer codes for the core and the factor matrices, the steps that scale them, a per-brick
/// error table and an optional sparse correction, range-coded (strata/core/range_coder.hpp).
///
/// Values are uniform scalar quantizations: core coefficient = code × core_step, factor entry of
/// column r of U^(n) = code × factor_step(step code of that column), correction of voxel i =
/// code × correction_step. The steps are chosen by the encoder (ta/target_codec.hpp); this module
/// only stores them. Byte layout (little endian), also in docs/format.md ("Coded Tucker brick"):
///
/// | offset | field | type | meaning |
/// | --- | --- | --- | --- |
/// | 0 | layout | u8 | 2 (1: format 1.1, block-DCT cores with the Tucker contexts; still read) |
/// | 1 | flags | u8 | bit 0: a sparse correction follows; bit 1: block-DCT factors |
/// | 2 | I1, I2, I3 | u16 ×3 | brick extents |
/// | 8 | R1, R2, R3 | u16 ×3 | stored ranks; all 0: the brick is `offset` (plus corrections); at most the extent, or extent − 2·margin with block-DCT factors |
/// | 14 | offset | f32 | added to every reconstructed voxel (the brick mean) |
/// | 18 | core_step | f32 | Δ of the core codes |
/// | 22 | dct_block, margin | u8 ×2 | only with flag bit 1 (block-DCT basis) |
/// | … | correction_step | f32 | only with flag bit 0 |
/// | … | factor step codes | u8 × (R1+R2+R3) | column r of U1, then U2, U3: step 2^(-code/8) |
/// | … | error table | u8 × max(R_n) | entry K-1: upper bound of the brick's RMSE at leading ranks K |
/// | … | range-coded stream | bytes | factor codes (U1, U2, U3, column-major), core codes (first index fastest), corrections |
///
/// Block-DCT factors: rows [margin, B - margin) of every factor are the orthonormal DCT-II basis
/// of blocks of dct_block rows, column c = frequency (c / blocks) of block (c % blocks), so the
/// leading columns are the lowest frequencies of every block; only the 2·margin overlap rows of
/// each column are coded (rows 0..margin-1, then B-margin..B-1). Otherwise every row is coded.
///
/// Error-table codes: 0 means an error of 0, c >= 1 means core_step × 2^((c - 64) / 4) (rounded up
/// when written, so an entry is never below the error it stands for).
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "strata/quant/brick.hpp"
#include "strata/tensor/tensor3.hpp"

namespace strata::quant {

struct CodedBrick {
  tensor::Dims3 dims{0, 0, 0};
  tensor::Ranks3 ranks{0, 0, 0};  // {0, 0, 0}: no Tucker model, the brick is `offset`
  float offset = 0;
  float core_step = 0;
  std::uint8_t dct_block = 0;  // 0: factors coded row by row; w > 0: block-DCT factors (above)
  std::uint8_t margin = 0;     // block-DCT factors: overlap rows per side
  std::vector<std::uint8_t> factor_step_codes;  // R1 + R2 + R3
  std::vector<std::int32_t> core_codes;         // R1 R2 R3, first index fastest
  std::vector<std::int32_t> factor_codes;       // U1 | U2 | U3, each column-major
  std::vector<std::uint8_t> error_table;        // max(R_n) codes (see error_code)
  float correction_step = 0;                    // 0: no correction
  std::vector<std::uint32_t> correction_index;  // strictly ascending voxel indices (first index fastest)
  std::vector<std::int32_t> correction_codes;   // non-zero, one per index
  bool operator==(const CodedBrick&) const = default;
};

/// @brief Entry (row, column) of the orthonormal block-DCT basis of `rows` rows in blocks of
/// `block` (columns frequency-major; see above). Computed in double, rounded once to float.
float block_dct_entry(int rows, int block, int row, int column);
/// @brief The whole basis of block_dct_entry, rows × rows, column-major (entry (row, column) at
/// row + rows · column), cached per thread (valid until eight other bases were asked for on the
/// same thread). Throws ParameterError("block") unless blocks of
/// `block` tile `rows`.
std::span<const float> block_dct_basis(int rows, int block);

/// @brief Factor codes stored per column: every row, or the overlap rows of a block-DCT brick.
std::int64_t coded_rows(const CodedBrick& brick, int mode);

/// @brief The factor step of a step code: 2^(-code/8), identical on every machine (no libm).
float factor_step(std::uint8_t code);
/// @brief The smallest step code whose step is at most `max_step` (codes stop at kMaxFactorStepCode).
std::uint8_t factor_step_code(double max_step);
inline constexpr std::uint8_t kMaxFactorStepCode = 240;  // step 2^-30: codes of |u| <= 1 fit in 31 bits

/// @brief Error-table code of `bound` relative to `core_step`, rounded up (never below `bound`).
std::uint8_t error_code(double bound, float core_step);
/// @brief The error a table code stands for (infinity for the saturated code 255).
double error_value(std::uint8_t code, float core_step);

inline constexpr std::uint8_t kCodedLayout = 2;        // written
inline constexpr std::uint8_t kOldestCodedLayout = 1;  // still read

/// @brief The payload bytes. Throws Error when a field is inconsistent (sizes, non-finite steps,
/// correction indices not ascending or beyond the brick), ParameterError for an unknown layout
/// (an older layout is only written to test that it still reads).
std::vector<std::byte> serialize(const CodedBrick& brick, std::uint8_t layout = kCodedLayout);

/// @brief Parses and validates a payload of a brick `brick_width` wide along every axis. Throws
/// FormatError(context, "coded brick …", problem) when it is truncated, has other extents, is
/// inconsistent or its range-coded stream is corrupt; never reads outside `bytes`.
CodedBrick deserialize_coded(std::span<const std::byte> bytes, int brick_width, const std::string& context);

/// @brief Bytes of a serialized brick before its range-coded stream.
std::size_t coded_header_bytes(const CodedBrick& brick);

/// @brief The float model: core and factors scaled by their steps, the offset and the
/// correction. Reuses the buffers of `out`.
void dequantize(const CodedBrick& brick, DequantizedModel& out);

}  // namespace strata::quant
