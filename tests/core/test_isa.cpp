// The instruction-set levels and the one limit every kernel obeys (strata/core/isa.hpp).
#include <gtest/gtest.h>

#include "strata/core/error.hpp"
#include "strata/core/isa.hpp"

using namespace strata;

TEST(CoreIsa, NamesRoundTripAndUnknownNamesAreRejected) {
  for (Isa isa : kAllIsas) EXPECT_EQ(parse_isa(isa_name(isa)), isa);
  EXPECT_EQ(parse_isa("sse42"), Isa::sse42);
  EXPECT_EQ(parse_isa("avx"), std::nullopt);
  EXPECT_EQ(parse_isa(""), std::nullopt);
  EXPECT_EQ(parse_isa("AVX2"), std::nullopt);
}

TEST(CoreIsa, SupportIsCumulativeAndTheMachineLevelIsTheWidest) {
  EXPECT_TRUE(isa_supported(Isa::generic));
  for (std::size_t i = 1; i < kAllIsas.size(); ++i)
    if (isa_supported(kAllIsas[i])) {
      EXPECT_TRUE(isa_supported(kAllIsas[i - 1])) << isa_name(kAllIsas[i]);
    }
  EXPECT_TRUE(isa_supported(machine_isa()));
  for (Isa isa : kAllIsas)
    if (isa > machine_isa()) {
      EXPECT_FALSE(isa_supported(isa)) << isa_name(isa);
    }
  EXPECT_LE(active_isa(), machine_isa());
}

TEST(CoreIsa, ScopedLimitsNestAndRestore) {
  const Isa before = active_isa();
  {
    const ScopedIsaLimit generic(Isa::generic);
    EXPECT_EQ(active_isa(), Isa::generic);
    {
      const ScopedIsaLimit widest(machine_isa());
      EXPECT_EQ(active_isa(), machine_isa());
    }
    EXPECT_EQ(active_isa(), Isa::generic);
  }
  EXPECT_EQ(active_isa(), before);
}

TEST(CoreIsa, ALevelAboveTheMachineIsRejectedAndLeavesTheLimit) {
  if (machine_isa() == Isa::avx512) GTEST_SKIP() << "this CPU supports every level";
  const Isa before = active_isa();
  try {
    set_isa_limit(Isa::avx512);
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("avx512"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ScopedIsaLimit{Isa::avx512}, Error);
  EXPECT_EQ(active_isa(), before);
}
