#include "ta/raw_brick.hpp"

#include <cstring>

#include "strata/core/error.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::ta {

void split_byte_planes(std::span<const std::byte> in, std::span<std::byte> out, std::size_t width) {
  const std::size_t n = in.size() / width;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t p = 0; p < width; ++p) out[p * n + i] = in[width * i + p];
  for (std::size_t i = n * width; i < in.size(); ++i) out[i] = in[i];
}

void merge_byte_planes(std::span<const std::byte> in, std::span<std::byte> out, std::size_t width) {
  const std::size_t n = in.size() / width;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t p = 0; p < width; ++p) out[width * i + p] = in[p * n + i];
  for (std::size_t i = n * width; i < in.size(); ++i) out[i] = in[i];
}

std::vector<std::byte> encode_raw_brick(std::span<const float> samples, int zstd_level) {
  const auto bytes = std::as_bytes(samples);
  std::vector<std::byte> planes(bytes.size());
  split_byte_planes(bytes, planes, sizeof(float));
  return store::zstd_compress(planes, zstd_level > 0 ? zstd_level : 3);
}

void decode_raw_brick(std::span<const std::byte> payload, std::span<float> out, std::vector<std::byte>& scratch,
                      const std::string& context) {
  const std::uint64_t expected = out.size() * sizeof(float);
  store::zstd_decompress(payload, expected, scratch, context, "raw brick");
  if (scratch.size() != expected)
    throw FormatError(context, "raw brick",
                      "inflates to " + std::to_string(scratch.size()) + " bytes, expected " + std::to_string(expected));
  merge_byte_planes(scratch, std::as_writable_bytes(out), sizeof(float));
}

}  // namespace strata::ta
