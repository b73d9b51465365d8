#pragma once
/// @file
/// @brief The payload kinds of the .strata brick index and what each one is: the one table of
/// their traits (name, what the payload stores, its alignment, the format version that added
/// it, and which decoder reads it). Code that needs a property of a kind asks this table;
/// a `switch` over kinds is a compile error when a kind is missing (-Werror=switch).
///
/// Adding a kind: a new enumerator, one row of kPayloadKinds (the static_asserts below keep the
/// table complete and in code order), its byte layout in docs/format.md and, when no decoder
/// of PayloadDecoder reads it, a new decoder there and in ta/brick_codec.cpp.
#include <array>
#include <cstdint>
#include <string_view>

namespace strata::store {

/// @brief What a brick's payload holds (the index's `kind` byte). New codecs add kinds;
/// readers reject kinds they do not know.
enum class PayloadKind : std::uint8_t {
  constant = 1,          ///< no payload bytes: every voxel equals `min` (== `max`)
  tucker = 2,            ///< quantized rank-reduced Tucker brick (ta module, docs/format.md)
  tucker_zstd = 3,       ///< the same bytes, factor codes split into byte planes, then zstd-compressed
  tucker_coded = 4,      ///< Tucker brick coded to an error target (quant/coded_brick.hpp), format 1.1
  raw_zstd = 5,          ///< the float samples, byte planes, zstd: lossless (ta/raw_brick.hpp), format 1.1
  raw_packed = 6,        ///< the samples' non-repeating box, integer codes where exact, zstd: lossless, format 1.3
  masked = 7,            ///< NaN or infinite voxels: their mask, then the brick of the others (ta/non_finite.hpp), format 1.4
  global_core = 8,       ///< a core-only quantized brick on the volume's global row-block bases (ta-global), format 1.5
  global_core_zstd = 9,  ///< the same bytes, zstd-compressed (ta-global), format 1.5
};

/// @brief Which decoder of the `ta` module reads a payload kind (ta/brick_codec.cpp switches
/// over this, so a decoder without a case does not compile).
enum class PayloadDecoder : std::uint8_t {
  none,          ///< constant bricks: the index entry's `min` is every voxel
  tucker,        ///< a quantized Tucker brick with its own factors (quant::BrickView)
  coded_tucker,  ///< a Tucker brick coded to an error target (quant::deserialize_coded)
  lossless,      ///< the samples themselves (ta/raw_brick.hpp)
  global_core,   ///< a core only; the factors are the volume's global row-block bases
  masked,        ///< a mask of non-finite voxels around an inner payload of another kind
};

/// @brief The traits of one payload kind.
struct PayloadKindTraits {
  PayloadKind kind;
  std::string_view name;          ///< as `strata info` and messages print it
  std::uint16_t since_minor;      ///< the format 1.x minor version that added it
  PayloadDecoder decoder;
  bool has_factors;               ///< stores its own factor matrices
  bool has_core;                  ///< stores a core tensor
  bool has_mask;                  ///< stores a mask of NaN and infinite voxels
  bool zstd;                      ///< a zstd frame over the plain layout of its decoder
  /// Starts at a multiple of kPayloadAlignment: fixed-layout code arrays a decoder may want to
  /// address in place. Entropy-coded kinds are always copied and decoded, so they are packed
  /// without padding; `constant` has no bytes. The compressed index derives offsets from this.
  bool aligned;
  /// May be the inner brick of a `masked` payload (docs/format.md, "Masked brick payload").
  bool maskable;
};

// clang-format off
/// @brief Every payload kind, in code order (kind n at index n - 1).
inline constexpr std::array<PayloadKindTraits, 9> kPayloadKinds{{
  //  kind                           name                since decoder                        factors core   mask   zstd   aligned maskable
  {PayloadKind::constant,         "constant",         0, PayloadDecoder::none,          false, false, false, false, false, true},
  {PayloadKind::tucker,           "tucker",           0, PayloadDecoder::tucker,        true,  true,  false, false, true,  true},
  {PayloadKind::tucker_zstd,      "tucker_zstd",      0, PayloadDecoder::tucker,        true,  true,  false, true,  true,  true},
  {PayloadKind::tucker_coded,     "tucker_coded",     1, PayloadDecoder::coded_tucker,  true,  true,  false, false, false, true},
  {PayloadKind::raw_zstd,         "raw_zstd",         1, PayloadDecoder::lossless,      false, false, false, true,  false, true},
  {PayloadKind::raw_packed,       "raw_packed",       3, PayloadDecoder::lossless,      false, false, false, true,  false, true},
  {PayloadKind::masked,           "masked",           4, PayloadDecoder::masked,        false, false, true,  true,  false, false},
  {PayloadKind::global_core,      "global_core",      5, PayloadDecoder::global_core,   false, true,  false, false, false, false},
  {PayloadKind::global_core_zstd, "global_core_zstd", 5, PayloadDecoder::global_core,   false, true,  false, true,  false, false},
}};
// clang-format on

namespace detail {
constexpr bool payload_kinds_in_code_order() {
  for (std::size_t i = 0; i < kPayloadKinds.size(); ++i)
    if (std::size_t(kPayloadKinds[i].kind) != i + 1) return false;
  return true;
}
}  // namespace detail
static_assert(detail::payload_kinds_in_code_order(), "kPayloadKinds: kind n belongs at index n - 1");
static_assert(std::size_t(PayloadKind::global_core_zstd) == kPayloadKinds.size(),
              "kPayloadKinds: a row for every payload kind (update this check with the last kind)");

/// @brief The traits of the kind whose index code is `code`; nullptr for a code no kind has
/// (a damaged file, or one written by a newer version).
constexpr const PayloadKindTraits* find_payload_kind(std::uint8_t code) {
  return code >= 1 && code <= kPayloadKinds.size() ? &kPayloadKinds[code - 1] : nullptr;
}

/// @brief The traits of `kind`, which must be a known kind (checked: an unknown value, e.g.
/// one cast from a damaged index byte, throws Error).
const PayloadKindTraits& payload_kind_traits(PayloadKind kind);

/// @brief The kind's name ("tucker_zstd"), or "unknown" for a value no kind has.
const char* payload_kind_name(PayloadKind kind);

/// @brief Whether a payload of `kind` starts at a multiple of kPayloadAlignment
/// (PayloadKindTraits::aligned); false for a value no kind has.
bool needs_alignment(PayloadKind kind);

}  // namespace strata::store
