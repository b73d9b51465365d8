#include "strata/store/byte_planes.hpp"

namespace strata::store {

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

}  // namespace strata::store
