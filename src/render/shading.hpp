#pragma once
// Shading shared by the ray caster's scalar and 8-lane marches: the opacity below which a
// segment is not shaded, and Blinn-Phong's specular power: x^n for an integer n >= 0 by repeated
// squaring. The default exponent (24) also has a compile-time form, unrolled with the same
// products in the same order (the generic loop's first product 1 * x^(2^i) is exact), so both
// give the same bits; the ray caster's 8-lane march repeats that sequence on vectors.
namespace strata::render::detail {

// Segments below this opacity per level-0 voxel of length skip the gradient (the stencil's extra
// taps). Each level's threshold is this one corrected to its step (LevelParams::shade_threshold),
// so whether a material is lit does not depend on the step: a fixed per-segment threshold left
// low-opacity material unlit at small steps, a bias that no step refinement removed.
inline constexpr float kShadeThreshold = 1.0f / 1024.0f;

inline float power(float x, int n) {  // x^n, n >= 0, by repeated squaring
  float r = 1.0f;
  while (n > 0) {
    if (n & 1) r *= x;
    x *= x;
    n >>= 1;
  }
  return r;
}

// power(x, N) unrolled: r is 1 until the lowest set bit (Started == false).
template <int N, bool Started = false>
[[gnu::always_inline]] inline float power_fixed(float x, float r = 1.0f) {
  if constexpr (N == 0) {
    return r;
  } else {
    if constexpr ((N & 1) != 0) r = Started ? r * x : x;
    if constexpr ((N >> 1) == 0) return r;
    else return power_fixed<(N >> 1), Started || (N & 1) != 0>(x * x, r);
  }
}

inline constexpr int kFixedShininess = 24;  // ShadingParams' default

[[gnu::always_inline]] inline float specular_power(float x, int n) {
  return n == kFixedShininess ? power_fixed<kFixedShininess>(x) : power(x, n);
}

}  // namespace strata::render::detail
