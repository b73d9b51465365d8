#pragma once
// Register-tiled GEMM used for the three n-mode products of brick reconstruction. Private to
// src/tensor: reconstruct_kernel.cpp instantiates it once per instruction set.
#include <cstdint>

namespace strata::tensor::detail {

// Out(M x N) = L(M x K) · R(K x N).
// L and Out are column-major with leading dimensions ld_l and ld_out (contiguous rows within a
// column, which is what the vector loads and stores use); R is read one scalar at a time, at
// r[k * r_k + n * r_n], so it can be the core tensor (stage 1) or a transposed factor matrix
// (stages 2 and 3) without copying.
struct GemmArgs {
  std::int64_t m = 0, n = 0, k = 0;
  const float* l = nullptr;
  std::int64_t ld_l = 0;
  const float* r = nullptr;
  std::int64_t r_k = 0, r_n = 0;
  float* out = nullptr;
  std::int64_t ld_out = 0;
};

// One brick reconstruction, all pointers set up by BrickReconstructor.
struct ReconstructArgs {
  std::int64_t i1 = 0, i2 = 0, i3 = 0;  // brick extents
  int k1 = 0, k2 = 0, k3 = 0;           // ranks used
  const float* core = nullptr;          // contiguous k1 x k2 x k3
  const float* u1 = nullptr;            // i1 x k1, ld i1
  const float* u2 = nullptr;            // i2 x k2, ld i2
  const float* u3 = nullptr;            // i3 x k3, ld i3
  float* t1 = nullptr;                  // scratch i1 x k2 x k3
  float* t2 = nullptr;                  // scratch i1 x i2 x k3
  float* out = nullptr;                 // i1 x i2 x i3
};

// The three products in the paper's order (Eq. A.3): the row count of every GEMM is a multiple of
// I1, so for B = 32 every row block fills whole vectors and only the column tail may be scalar.
//   T1 = B ×1 U1      : T1 (I1 x K2K3)       = U1 · B_(1)
//   T2 = T1 ×2 U2     : T2(:,:,r3) (I1 x I2) = T1(:,:,r3) · U2^T      for each r3
//   A  = T2 ×3 U3     : A (I1I2 x I3)        = T2 · U3^T
// `narrow` runs the first two products (I1 rows), `wide` the last (I1 I2 rows, most of the work),
// so each can use the register tile that suits its shape.
template <class Narrow, class Wide>
inline void reconstruct_with(const ReconstructArgs& a, Narrow&& narrow, Wide&& wide) {
  narrow(GemmArgs{a.i1, std::int64_t(a.k2) * a.k3, a.k1, a.u1, a.i1, a.core, 1, a.k1, a.t1, a.i1});
  for (int r3 = 0; r3 < a.k3; ++r3) {
    narrow(GemmArgs{a.i1, a.i2, a.k2, a.t1 + std::int64_t(r3) * a.i1 * a.k2, a.i1, a.u2, a.i2, 1,
                  a.t2 + std::int64_t(r3) * a.i1 * a.i2, a.i1});
  }
  wide(GemmArgs{a.i1 * a.i2, a.i3, a.k3, a.t2, a.i1 * a.i2, a.u3, a.i3, 1, a.out, a.i1 * a.i2});
}

// One projection (the analysis transform), all pointers set up by BrickProjector:
// core = X[box] ×1 U1^T ×2 U2^T ×3 U3^T. The first product's row count is padded to `mp` (a
// multiple of every vector width) with zero rows in Ut1, so all three products run on whole
// vectors; the caller drops the padded rows.
struct ProjectArgs {
  std::int64_t e1 = 0, e2 = 0, e3 = 0;  // box extents
  int r2 = 0, r3 = 0;                   // output ranks of modes 2 and 3
  std::int64_t mp = 0;                  // rank of mode 1, padded
  const float* x = nullptr;             // the box's first sample
  std::int64_t x_j = 0, x_k = 0;        // strides of modes 2 and 3 in x (mode 1 is contiguous)
  const float* ut1 = nullptr;           // mp x e1, ld mp: U1^T and zero rows
  const float* u2 = nullptr;            // e2 x r2, ld e2
  const float* u3 = nullptr;            // e3 x r3, ld e3
  float* t1 = nullptr;                  // scratch mp x e2 x e3
  float* t2 = nullptr;                  // scratch mp x r2 x e3
  float* out = nullptr;                 // mp x r2 x r3
};

//   T1(:,:,s) (mp x e2)  = Ut1 · X(:,:,s)          for each slice s of the box
//   T2(:,:,s) (mp x r2)  = T1(:,:,s) · U2           for each s
//   Out (mp r2 x r3)     = T2 (mp r2 x e3) · U3
template <class Narrow, class Wide>
inline void project_with(const ProjectArgs& a, Narrow&& narrow, Wide&& wide) {
  for (std::int64_t s = 0; s < a.e3; ++s)
    narrow(GemmArgs{a.mp, a.e2, a.e1, a.ut1, a.mp, a.x + s * a.x_k, 1, a.x_j, a.t1 + s * a.mp * a.e2, a.mp});
  for (std::int64_t s = 0; s < a.e3; ++s)
    narrow(GemmArgs{a.mp, a.r2, a.e2, a.t1 + s * a.mp * a.e2, a.mp, a.u2, 1, a.e2, a.t2 + s * a.mp * a.r2, a.mp});
  wide(GemmArgs{a.mp * a.r2, a.r3, a.e3, a.t2, a.mp * a.r2, a.u3, 1, a.e3, a.out, a.mp * a.r2});
}

void reconstruct_generic(const ReconstructArgs& a);
void reconstruct_avx2(const ReconstructArgs& a);
void reconstruct_avx512(const ReconstructArgs& a);
void project_generic(const ProjectArgs& a);
void project_avx2(const ProjectArgs& a);
void project_avx512(const ProjectArgs& a);

}  // namespace strata::tensor::detail
