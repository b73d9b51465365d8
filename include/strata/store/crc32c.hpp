#pragma once
/// @file
/// @brief CRC-32C, the checksum of every payload, section and header of a .strata file.
#include <cstddef>
#include <cstdint>

namespace strata::store {

// CRC-32C (Castagnoli polynomial, reflected 0x82F63B78), as used by iSCSI, ext4 and
// compressed_segmentation: the SSE4.2 instruction when active_isa() allows it
// (strata/core/isa.hpp), else slicing-by-8 tables; both give the same value. Thread-safe.
std::uint32_t crc32c(const void* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace strata::store
