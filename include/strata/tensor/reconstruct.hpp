#pragma once
// The renderer's hot path: reconstructing a brick from its Tucker model (paper §5.2) as three
// successive n-mode products B ×1 U1 ×2 U2 ×3 U3, each a small GEMM run by a register-tiled
// kernel compiled for AVX-512, AVX2+FMA and baseline x86-64 and picked at run time by the
// active instruction-set level (strata/core/isa.hpp), so the portable build is as fast as a
// -march=native one. Work per voxel grows linearly with the rank.
#include <cstddef>
#include <memory>
#include <span>
#include <string_view>

#include "strata/tensor/tucker.hpp"

namespace strata::tensor {

// Non-owning float view of a Tucker model, as a decoder produces it from dequantized codes.
struct TuckerView {
  const float* core = nullptr;                 // ranks[0] x ranks[1] x ranks[2], first index fastest
  Ranks3 ranks{0, 0, 0};                       // R1, R2, R3
  std::array<const float*, 3> factors{};       // U^(n): dims[n] x ranks[n], column-major, ld = dims[n]
  Dims3 dims{0, 0, 0};                         // I1, I2, I3 of the reconstructed brick
};

TuckerView view_of(const Tucker& model);

// Reconstructs bricks into caller-provided buffers. Holds the scratch tensors between the three
// products (I1 x K2 x K3 and I1 x I2 x K3) and grows them only when a larger brick arrives, so a
// loop over equally sized bricks allocates nothing. One instance per thread (not thread-safe).
class BrickReconstructor {
 public:
  // Each call runs the kernel variant active_isa() allows (strata/core/isa.hpp).
  BrickReconstructor();
  ~BrickReconstructor();
  BrickReconstructor(BrickReconstructor&&) noexcept;
  BrickReconstructor& operator=(BrickReconstructor&&) noexcept;

  // out = B[:K1, :K2, :K3] ×1 U1[:, :K1] ×2 U2[:, :K2] ×3 U3[:, :K3], i.e. the model truncated to
  // its leading ranks (1 <= K_n <= R_n). `out` holds I1 I2 I3 floats, first index fastest.
  void reconstruct(const TuckerView& model, const Ranks3& leading_ranks, std::span<float> out);
  // Full rank (K = R).
  void reconstruct(const TuckerView& model, std::span<float> out);
  // Convenience for owning models; `leading_ranks` as above.
  Tensor3 reconstruct(const Tucker& model, const Ranks3& leading_ranks);

 private:
  struct Scratch;
  std::unique_ptr<Scratch> scratch_;
};

/// @brief The analysis counterpart of BrickReconstructor: the core of a box of a brick in given
/// bases, B = X[box] ×1 U1ᵀ ×2 U2ᵀ ×3 U3ᵀ, on the same dispatched GEMM kernel (the encoder's
/// block-DCT and HOSVD projections; Eigen's portable build would run them on SSE2 only). Keeps
/// its scratch between calls; one instance per thread (not thread-safe).
class BrickProjector {
 public:
  BrickProjector();
  ~BrickProjector();
  BrickProjector(BrickProjector&&) noexcept;
  BrickProjector& operator=(BrickProjector&&) noexcept;

  /// @brief `x` holds a brick of `dims` samples (first index fastest); the box starts at `lo`
  /// and spans `bases.dims`. bases.factors[n] is bases.dims[n] x bases.ranks[n], column-major
  /// (bases.core is not read). Writes the ranks[0] x ranks[1] x ranks[2] core into `core`.
  /// Throws Error if the box leaves the brick or a factor pointer is null.
  void project(std::span<const float> x, const Dims3& dims, const Dims3& lo, const TuckerView& bases, Tensor3& core);

 private:
  struct Scratch;
  std::unique_ptr<Scratch> scratch_;
};

}  // namespace strata::tensor
