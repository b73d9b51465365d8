#pragma once
// A quantized Tucker brick (paper 1 §4): codes for the core and the three factor matrices plus
// the few floats needed to decode them, and its byte serialization, which a container stores.
//
// Serialized layout (little endian, sizes fixed by the scheme, dims and ranks):
//   u16 I1, I2, I3, R1, R2, R3                                  12 bytes
//   f32 parameters, in this order, each only if the scheme has it:
//     factor_lo, factor_hi   (linear factors)
//     core_lo, core_hi       (linear core)
//     core_max_abs           (log and mu-law core)
//     mu                     (mu-law core)
//     hot_corner             ("+" schemes)
//   core codes:   R1 R2 R3 codes of core_bits, first index fastest, packed (bitpack.hpp)
//   factor codes: U1, U2, U3 each column-major, I_n R_n codes of factor_bits, one packed stream
// "f32" parts store the raw float bits as 32-bit codes.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "strata/quant/scheme.hpp"
#include "strata/tensor/reconstruct.hpp"
#include "strata/tensor/tucker.hpp"

namespace strata::quant {

// The floats stored beside the codes (unused ones stay 0).
struct BrickParams {
  float factor_lo = 0, factor_hi = 0;  // Eq. 1 range shared by U1, U2, U3
  float core_lo = 0, core_hi = 0;      // linear core range
  float core_max_abs = 0;              // log / mu-law core: max |b| over the coded coefficients
  float mu = 0;                        // mu-law core
  float hot_corner = 0;                // "+" schemes: B(0,0,0), exact
  bool operator==(const BrickParams&) const = default;
};

struct QuantizedBrick {
  tensor::Dims3 dims{0, 0, 0};
  tensor::Ranks3 ranks{0, 0, 0};
  BrickParams params;
  std::vector<std::uint32_t> core_codes;    // R1 R2 R3, first index fastest
  std::vector<std::uint32_t> factor_codes;  // U1 | U2 | U3, each column-major
  bool operator==(const QuantizedBrick&) const = default;
};

// Quantizes a model. In "+" schemes B(0,0,0) is kept as a float and excluded from the core's
// range (so the other coefficients get the resolution), and its slot is coded as 0.
// Throws Error on non-finite coefficients or extents/ranks beyond 65535.
QuantizedBrick quantize(const tensor::Tucker& model, const QuantScheme& scheme);

/// @brief A core-only brick (extents {0, 0, 0}, no factor codes): the global-basis codec's
/// per-brick core, whose factors are the volume's row-block bases. Serialized like any brick
/// (its factor parameters, if the scheme stores any, are 0); BrickView reads it and refuses
/// dequantize_factor; dequantize() leaves the model's factors to the caller.
QuantizedBrick quantize_core_only(const tensor::Tensor3& core, const QuantScheme& scheme);

std::size_t serialized_size(const QuantScheme& scheme, const tensor::Dims3& dims, const tensor::Ranks3& ranks);
std::vector<std::byte> serialize(const QuantizedBrick& brick, const QuantScheme& scheme);
QuantizedBrick deserialize(std::span<const std::byte> bytes, const QuantScheme& scheme);

// Zero-copy view of serialized bytes: the decode path. The constructor validates the header and
// that the byte count is exactly what the scheme, extents and ranks require; the bytes must
// outlive the view.
class BrickView {
 public:
  BrickView(std::span<const std::byte> bytes, const QuantScheme& scheme);

  const tensor::Dims3& dims() const { return dims_; }
  const tensor::Ranks3& ranks() const { return ranks_; }
  const BrickParams& params() const { return params_; }
  const QuantScheme& scheme() const { return scheme_; }

  // The leading K1 x K2 x K3 block of the dequantized core, contiguous (first index fastest),
  // with the exact hot corner restored. `out` holds K1 K2 K3 floats; 1 <= K_n <= R_n.
  void dequantize_core(const tensor::Ranks3& leading, std::span<float> out) const;
  // The first `leading` columns of U^(mode) (mode 1..3), column-major I_n x leading.
  void dequantize_factor(int mode, int leading, std::span<float> out) const;

 private:
  QuantScheme scheme_;
  tensor::Dims3 dims_{0, 0, 0};
  tensor::Ranks3 ranks_{0, 0, 0};
  BrickParams params_;
  const std::byte* core_ = nullptr;
  const std::byte* factors_ = nullptr;
};

// Float buffers a decoder fills for BrickReconstructor; reusing one instance across bricks of
// the same size allocates nothing.
// Coded bricks (coded_brick.hpp) add an offset, a sparse correction and, for bricks stored
// losslessly, the samples themselves; quantized bricks leave those empty.
struct DequantizedModel {
  std::vector<float> core;                  // ranks[0] x ranks[1] x ranks[2]
  std::array<std::vector<float>, 3> factors;  // dims[n] x ranks[n], column-major
  tensor::Dims3 dims{0, 0, 0};
  tensor::Ranks3 ranks{0, 0, 0};  // the leading ranks that were decoded; {0, 0, 0}: no Tucker part
  float offset = 0;               // added to every voxel
  // Added to voxel correction_index[i] when the model is reconstructed at its full ranks.
  std::vector<std::uint32_t> correction_index;
  std::vector<float> correction_value;
  std::vector<float> samples;  // non-empty: a losslessly stored brick (no Tucker part)
  // Written over the reconstruction at any rank: the brick's NaN and infinite voxels (payload
  // kind `masked`; set by ta::dequantize_brick, empty otherwise).
  std::vector<std::uint32_t> non_finite_index;
  std::vector<float> non_finite_value;
  bool has_tucker() const { return ranks[0] > 0 && ranks[1] > 0 && ranks[2] > 0; }
  tensor::TuckerView view() const;
};

// Dequantizes the leading ranks of a brick into `out`.
void dequantize(const BrickView& brick, const tensor::Ranks3& leading, DequantizedModel& out);

// Full-rank owning model (tests, evaluation tools).
tensor::Tucker dequantize(const QuantizedBrick& brick, const QuantScheme& scheme);

}  // namespace strata::quant
