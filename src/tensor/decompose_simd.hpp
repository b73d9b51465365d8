#pragma once
// Vector helpers shared by the decomposition kernels (decompose_gemm.cpp, decompose_gram.cpp,
// decompose_eigen.cpp). Private to src/tensor. Each kernel is an always_inline template over the
// vector width VW (doubles per register: 8 for AVX-512, 4 for AVX2, 2 for SSE2) inlined into an
// entry point compiled for one instruction-set level (STRATA_TARGET_* of strata/core/isa.hpp), so
// `acc += a * b` on vector types becomes one FMA where the target has one. Tile sizes follow the
// register files (32 zmm vs 16 ymm/xmm): accumulators plus loaded operands must fit, or the
// compiler spills.
#include <cstdint>
#include <cstring>
#include <type_traits>

#include <immintrin.h>  // declares the AVX-512 builtins used below

#include "strata/core/isa.hpp"
#include "tensor/decompose_kernel.hpp"

// The helpers pass vectors by value; they are always inlined into a target-attributed entry
// point, so the ABI note about vector arguments without AVX enabled does not apply. It covers
// each including file on purpose: GCC reports it at the end of the translation unit, where the
// helper templates are instantiated, so a push/pop around the helpers does not reach it.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace strata::tensor::detail {


template <int VW>
struct DVecOf {
  typedef double type __attribute__((vector_size(VW * sizeof(double))));
};

// Lane masks and counters next to DVecOf (a dependent typedef inside a template drops
// vector_size, hence the struct).
template <int VW>
struct UVecOf {
  typedef std::uint64_t type __attribute__((vector_size(VW * sizeof(std::uint64_t))));
};
template <int VW>
struct LVecOf {
  typedef std::int64_t type __attribute__((vector_size(VW * sizeof(std::int64_t))));
};

// VW doubles from p (unaligned); float operands (the decompositions' input tensor) are widened
// on the fly, exactly.
template <int VW, class T>
[[gnu::always_inline]] inline typename DVecOf<VW>::type load(const T* p) {
  typename DVecOf<VW>::type v;
  if constexpr (std::is_same_v<T, double>) {
    __builtin_memcpy(&v, p, sizeof(v));
  } else if constexpr (VW == 8) {
    // One vcvtps2pd zmm, ymm (the generic conversion below becomes two half-width conversions and
    // a merge). A builtin, not the intrinsic: builtins are checked against the target of the
    // function they end up in (an AVX-512 entry point), intrinsics against this template's.
    typedef float F8 __attribute__((vector_size(32)));
    F8 f;
    __builtin_memcpy(&f, p, sizeof(f));
    v = __builtin_ia32_cvtps2pd512_mask((__v8sf)f, (__v8df)v, (__mmask8)-1, _MM_FROUND_CUR_DIRECTION);
  } else {
    typedef float F __attribute__((vector_size(VW * sizeof(float))));
    F f;
    __builtin_memcpy(&f, p, sizeof(f));
    v = __builtin_convertvector(f, typename DVecOf<VW>::type);
  }
  return v;
}

template <int VW>
[[gnu::always_inline]] inline void store(double* p, typename DVecOf<VW>::type v) {
  __builtin_memcpy(p, &v, sizeof(v));
}

template <int VW>
[[gnu::always_inline]] inline double hsum(typename DVecOf<VW>::type v) {
  double s = 0;
  for (int i = 0; i < VW; ++i) s += v[i];
  return s;
}

}  // namespace strata::tensor::detail
