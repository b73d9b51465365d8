#pragma once
/// @brief One zstd frame in, one out: the only place that calls the zstd library. Used for the
/// payloads and sections of `.strata` files (Tucker bricks of kind `tucker_zstd`, label id
/// sections) and their compressed brick index. Thread-safe: each thread keeps one compression and one decompression context.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace strata::store {

/// Compresses `in` at zstd `level` (1..22) into one frame that records its content size.
/// Throws Error when zstd fails.
std::vector<std::byte> zstd_compress(std::span<const std::byte> in, int level);

/// Decompresses the single frame `in` into `out` (resized to the frame's content size). Throws
/// FormatError(file, field, …) when `in` is not a zstd frame with a known content size, when that
/// size exceeds `limit` bytes (a corrupt header must not allocate without bound), or when the data
/// is corrupt or short.
void zstd_decompress(std::span<const std::byte> in, std::uint64_t limit, std::vector<std::byte>& out,
                     const std::string& file, const std::string& field);

}  // namespace strata::store
