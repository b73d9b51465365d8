#pragma once
#include <cstddef>
#include <cstdint>

namespace strata::store {

// CRC-32C (Castagnoli polynomial, reflected 0x82F63B78), as used by iSCSI, ext4 and
// compressed_segmentation: uses the SSE4.2 instruction when the CPU has it, else a table.
std::uint32_t crc32c(const void* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace strata::store
