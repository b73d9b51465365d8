#include "ta/raw_brick.hpp"

#include <cstring>

#include "strata/core/error.hpp"
#include "strata/store/byte_planes.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::ta {

std::vector<std::byte> encode_raw_brick(std::span<const float> samples, int zstd_level) {
  const auto bytes = std::as_bytes(samples);
  std::vector<std::byte> planes(bytes.size());
  store::split_byte_planes(bytes, planes, sizeof(float));
  return store::zstd_compress(planes, zstd_level > 0 ? zstd_level : 3);
}

void decode_raw_brick(std::span<const std::byte> payload, std::span<float> out, std::vector<std::byte>& scratch,
                      const std::string& context) {
  const std::uint64_t expected = out.size() * sizeof(float);
  store::zstd_decompress(payload, expected, scratch, context, "raw brick");
  if (scratch.size() != expected)
    throw FormatError(context, "raw brick",
                      "inflates to " + std::to_string(scratch.size()) + " bytes, expected " + std::to_string(expected));
  store::merge_byte_planes(scratch, std::as_writable_bytes(out), sizeof(float));
}

}  // namespace strata::ta
