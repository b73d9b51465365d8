#pragma once
/// @file
/// @brief Byte-plane transposition, the preconditioner in front of zstd for arrays of
/// multi-byte numbers (Tucker factor codes, lossless float bricks, the compressed brick index):
/// the high bytes of neighbouring values repeat while their low bytes are noise, so grouping
/// equal byte positions gives zstd long runs to match.
#include <cstddef>
#include <span>

namespace strata::store {

/// @brief Byte plane p of `in` (n = in.size() / width items of `width` bytes) goes to
/// out[p·n, (p + 1)·n); bytes after the last whole item are copied as they are. `out` must be
/// as long as `in`. merge_byte_planes is the inverse.
void split_byte_planes(std::span<const std::byte> in, std::span<std::byte> out, std::size_t width);
/// @brief The inverse of split_byte_planes: `in` holds the planes, `out` (as long) gets the items.
void merge_byte_planes(std::span<const std::byte> in, std::span<std::byte> out, std::size_t width);

}  // namespace strata::store
