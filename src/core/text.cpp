#include "strata/core/text.hpp"

namespace strata {

std::string joined_list(const std::vector<std::string>& items, std::string_view conjunction) {
  std::string text;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i + 1 == items.size() && i > 0) {
      text.append(" ").append(conjunction).append(" ");
    } else if (i > 0) {
      text.append(", ");
    }
    text.append(items[i]);
  }
  return text;
}

}  // namespace strata
