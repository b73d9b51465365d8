#pragma once
// Helpers shared by the tests that drive the built `strata` program.
#include <string>

#include "support/test_support.hpp"

namespace strata::test {

/// The command line that runs the built program with `args`, without progress output.
inline std::string strata_cmd(const std::string& args) {
  return std::string(STRATA_BINARY) + " --progress none " + args;
}

}  // namespace strata::test
