#pragma once
/// @file
/// @brief Text for messages and help: lists of names written as a person writes them.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace strata {

/// @brief `items` as a list in prose: "a", "a or b", "a, b or c" (with `conjunction` "or").
std::string joined_list(const std::vector<std::string>& items, std::string_view conjunction);

/// @brief A byte count as a person reads it: "512 B", "1.5 MiB", "2.0 TiB" (binary units up to PiB).
std::string human_bytes(std::uint64_t bytes);

}  // namespace strata
