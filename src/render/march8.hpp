#pragma once
// The 8-lane march over one block's lattice points (march8.cpp), for the scalar march that hands
// over to it (march.cpp): one declaration per instruction set, each carrying the attributes its
// definition is compiled with. Declared only where the x86-64 intrinsics exist.
#include <cstdint>

#include "render/frame_index.hpp"
#include "render/ray_sampling.hpp"
#include "render/ray_traversal.hpp"
#include "strata/core/isa.hpp"

namespace strata::render::detail {

#if STRATA_X86_64
// Marches lattice points k..k1-1 (k0: the block's first lattice point, p / dp its local position
// and step). `front` holds the value at `last` (== k - 1 on entry). Returns where it stopped
// (k1, or one past the sample that terminated the ray). Instantiated for Shade = false and true.
template <bool Shade>
[[gnu::optimize("fp-contract=off")]] STRATA_TARGET_AVX2 std::int64_t march8(
    const GridSampler& s, const Block& b, const LevelParams& lp, const MarchParams& mp, const RayContext& ray,
    const float p[3], const float dp[3], std::int64_t k0, std::int64_t k, std::int64_t k1, bool skip, float& front,
    std::int64_t& last, Rgbaf& acc_io, std::uint64_t& taken);

// The same loop compiled for AVX-512 (F/VL/BW/DQ).
template <bool Shade>
[[gnu::optimize("fp-contract=off")]] STRATA_TARGET_AVX512 std::int64_t march8_avx512(
    const GridSampler& s, const Block& b, const LevelParams& lp, const MarchParams& mp, const RayContext& ray,
    const float p[3], const float dp[3], std::int64_t k0, std::int64_t k, std::int64_t k1, bool skip, float& front,
    std::int64_t& last, Rgbaf& acc_io, std::uint64_t& taken);
#endif

}  // namespace strata::render::detail
