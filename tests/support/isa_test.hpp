#pragma once
/// @file
/// @brief Value-parameterised tests run once per instruction-set level (strata/core/isa.hpp).
///
/// A kernel family derives its fixture from IsaTest and instantiates it with
/// STRATA_INSTANTIATE_PER_ISA(Fixture, levels...) listing the levels it has a variant for above
/// generic; each test body runs its kernels under ScopedIsaLimit(isa()) and compares them with
/// the generic path under ScopedIsaLimit(Isa::generic). Levels this CPU lacks are skipped with
/// GTEST_SKIP naming the level, never run as a comparison of a path with itself.
#include <gtest/gtest.h>

#include <ostream>
#include <string>

#include "strata/core/isa.hpp"

namespace strata {
// Names a level in gtest's messages ("GetParam() = avx2").
inline void PrintTo(Isa isa, std::ostream* os) { *os << isa_name(isa); }
}  // namespace strata

namespace strata::test {

class IsaTest : public ::testing::TestWithParam<Isa> {
 protected:
  void SetUp() override {
    if (!isa_supported(GetParam()))
      GTEST_SKIP() << "this CPU does not support " << isa_name(GetParam()) << " (it supports up to "
                   << isa_name(machine_isa()) << ")";
  }
  Isa isa() const { return GetParam(); }
};

/// @brief Test-name suffix of a level: its name without characters gtest rejects ("sse42").
inline std::string isa_test_name(const ::testing::TestParamInfo<Isa>& info) {
  std::string name;
  for (char c : isa_name(info.param))
    if (c != '.') name += c;
  return name;
}

}  // namespace strata::test

#define STRATA_INSTANTIATE_PER_ISA(Fixture, ...) \
  INSTANTIATE_TEST_SUITE_P(PerIsa, Fixture, ::testing::Values(__VA_ARGS__), ::strata::test::isa_test_name)
