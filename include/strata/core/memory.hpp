#pragma once

#include <cstdint>

namespace strata {

/// @brief Bytes of physical memory of this machine (0 when the system does not say). Readers
/// refuse structures a header declares larger than a share of it before allocating them.
std::uint64_t physical_memory_bytes();

}  // namespace strata
