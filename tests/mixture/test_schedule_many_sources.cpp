// A graph bitstream may declare up to 2^32 - 1 sources in a few bytes (sources have no bits of
// their own): scheduling it must cost memory in its internal nodes only. Found by the
// mixture_graph fuzz target (a 45-byte input that ran over a minute and took 1 GB).
#include <gtest/gtest.h>

#include <limits>

#include "strata/mixture/schedule.hpp"

namespace strata::mixture {
namespace {

TEST(MixtureSchedule, ManySourcesCostNothingToSchedule) {
  MixtureGraph g;
  g.num_sources = std::numeric_limits<std::uint32_t>::max() - 3;
  const std::uint32_t n = g.num_sources;
  g.codebook.bits = 1;
  g.codebook.value = {0.25, 0.75};
  g.codebook.sigma = {0.0, 0.0};
  g.codebook.uses = {1, 1};
  // n = (0, 1), n + 1 = (n, 2), n + 2 = (5, 6): depths 1, 2, 1.
  g.nodes = {{0, 1, 0}, {n, 2, 1}, {5, 6, 0}};
  for (bool balanced : {false, true}) {
    const Schedule s = make_schedule(g, balanced);
    EXPECT_EQ(s.depth, 2u);
    ASSERT_EQ(s.order.size(), 3u);
    // n + 1 needs n before it: n runs in phase 1, n + 1 in phase 2.
    EXPECT_EQ(s.phase(2).size(), 1u);
    EXPECT_EQ(s.phase(2)[0], n + 1);
  }
}

}  // namespace
}  // namespace strata::mixture
