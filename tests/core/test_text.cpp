#include <gtest/gtest.h>

#include "strata/core/text.hpp"

namespace strata {
namespace {

TEST(CoreText, JoinedListReadsAsProse) {
  EXPECT_EQ(joined_list({}, "or"), "");
  EXPECT_EQ(joined_list({"a"}, "or"), "a");
  EXPECT_EQ(joined_list({"a", "b"}, "or"), "a or b");
  EXPECT_EQ(joined_list({"a", "b", "c"}, "and"), "a, b and c");
}

}  // namespace
}  // namespace strata
