#pragma once
/// @file
/// @brief The instruction sets Strata's kernels are compiled for, and the one switch that limits them.
///
/// Every SIMD kernel (tensor reconstruction and decomposition, quantized-code decoding, brick
/// statistics, the ray march, CRC-32C) is compiled once per instruction set it benefits from,
/// with the STRATA_TARGET_* attributes below, inside the portable x86-64 build. At run time each
/// kernel takes the widest variant it has that is not above active_isa(). The limit comes from
/// the environment variable STRATA_ISA or the CLI's global `--isa` option (set_isa_limit), so a
/// user, a test or a benchmark forces a path in one place for every kernel at once.
///
/// Levels are cumulative: each includes everything below it.
///   generic  baseline x86-64 (SSE2)
///   sse4.2   + SSE4.2 (the CRC32 instruction)
///   avx2     + AVX2 and FMA
///   avx512   + AVX-512 F, VL, BW and DQ (Skylake-SP and later)
#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

namespace strata {

enum class Isa : std::uint8_t { generic = 0, sse42 = 1, avx2 = 2, avx512 = 3 };

/// @brief Every level, narrowest first (for tests and benchmarks that run each in turn).
inline constexpr std::array<Isa, 4> kAllIsas{Isa::generic, Isa::sse42, Isa::avx2, Isa::avx512};

/// @brief "generic", "sse4.2", "avx2" or "avx512".
std::string_view isa_name(Isa isa);

/// @brief The level named `name` (as isa_name spells it; "sse42" is accepted too), or nullopt.
std::optional<Isa> parse_isa(std::string_view name);

/// @brief Whether this CPU (and OS) runs code compiled for `isa`. Thread-safe.
bool isa_supported(Isa isa);

/// @brief The widest level this CPU supports. Thread-safe.
Isa machine_isa();

/// @brief The level kernels may use: the machine's, lowered by the limit if one is set.
///
/// On first use reads STRATA_ISA (a level name; empty or unset = no limit) and throws
/// strata::Error naming the variable if the value is unknown or this CPU lacks that level.
/// A relaxed atomic load afterwards: cheap enough to call per kernel invocation.
Isa active_isa();

/// @brief Limits every kernel to `isa` and below (the CLI's `--isa`).
///
/// Throws strata::ParameterError("isa") if this CPU does not support `isa`. Not meant to be called while
/// kernels run on other threads: a kernel in flight may finish on the old level.
void set_isa_limit(Isa isa);

/// @brief Sets the limit for a scope and restores the previous one (tests, benchmarks).
class ScopedIsaLimit {
 public:
  /// Throws as set_isa_limit does.
  explicit ScopedIsaLimit(Isa isa);
  ~ScopedIsaLimit();
  ScopedIsaLimit(const ScopedIsaLimit&) = delete;
  ScopedIsaLimit& operator=(const ScopedIsaLimit&) = delete;

 private:
  Isa previous_;
};

}  // namespace strata

// 1 where the x86-64 variants and <immintrin.h> exist (GCC or Clang targeting x86-64); elsewhere
// every kernel has its generic variant only and active_isa() is Isa::generic.
#if defined(__x86_64__) && defined(__GNUC__)
#define STRATA_X86_64 1
#else
#define STRATA_X86_64 0
#endif

// Function attributes compiling one kernel variant for a level (GCC and Clang). Use only on
// code reached after checking active_isa() >= that level.
#define STRATA_TARGET_SSE42 __attribute__((target("sse4.2")))
#define STRATA_TARGET_AVX2 __attribute__((target("avx2,fma")))
// GCC vectorizes loops of AVX-512 variants with 256-bit registers unless told to prefer 512;
// clang (14) rejects that option inside target() and then drops the whole attribute, so its
// variants keep clang's default width (its explicit intrinsics are unaffected).
#if defined(__clang__)
#define STRATA_TARGET_AVX512 __attribute__((target("avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")))
#else
#define STRATA_TARGET_AVX512 \
  __attribute__((target("avx512f,avx512vl,avx512bw,avx512dq,avx2,fma,prefer-vector-width=512")))
#endif
