#pragma once
/// @brief The one 64-bit mixing function of the project: splitmix64's finaliser, a bijection
/// with full avalanche, cheap enough to call per voxel. Hash tables key on it and the
/// generators derive their counter-based noise from it, so changing it changes generated
/// volumes (their bytes are tested).
#include <cstdint>

namespace strata {

constexpr std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

}  // namespace strata
