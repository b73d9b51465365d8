#include "strata/mixture/schedule.hpp"

#include <algorithm>

namespace strata::mixture {

namespace {

// Levels of the internal nodes only (node N + i at [i]): sources need no entry, and a bitstream
// may declare up to 2^32 of them in a few bytes, so nothing here is sized by their number.
std::vector<std::uint32_t> internal_levels(const MixtureGraph& g) {
  const std::uint32_t N = g.num_sources;
  std::vector<std::uint32_t> level(g.nodes.size(), 0);
  auto level_of = [&](std::uint32_t id) { return id < N ? 0u : level[id - N]; };
  for (std::size_t i = 0; i < g.nodes.size(); ++i) level[i] = std::max(level_of(g.nodes[i].a), level_of(g.nodes[i].b)) + 1;
  return level;
}

}  // namespace

std::vector<std::uint32_t> topological_levels(const MixtureGraph& g) {
  std::vector<std::uint32_t> level(g.node_count(), 0);
  for (std::size_t i = 0; i < g.nodes.size(); ++i) {
    const auto& n = g.nodes[i];
    level[g.num_sources + i] = std::max(level[n.a], level[n.b]) + 1;
  }
  return level;
}

std::uint32_t topological_depth(const MixtureGraph& g) {
  const auto level = topological_levels(g);
  return level.empty() ? 0 : *std::max_element(level.begin(), level.end());
}

Schedule make_schedule(const MixtureGraph& g, bool balanced) {
  const auto internal_level = internal_levels(g);
  Schedule s;
  s.depth = internal_level.empty() ? 0 : *std::max_element(internal_level.begin(), internal_level.end());
  const std::uint32_t D = s.depth;
  const std::uint32_t N = g.num_sources;
  const std::size_t internal = g.nodes.size();
  s.phase_offsets.assign(std::size_t(D) + 1, 0);
  s.order.reserve(internal);
  if (!balanced) {
    std::vector<std::uint64_t> count(std::size_t(D) + 2, 0);
    for (std::size_t i = 0; i < internal; ++i) ++count[internal_level[i]];
    for (std::uint32_t p = 1; p <= D; ++p) s.phase_offsets[p] = s.phase_offsets[p - 1] + count[p];
    s.order.resize(internal);
    std::vector<std::uint64_t> cursor(s.phase_offsets.begin(), s.phase_offsets.end());
    for (std::size_t i = 0; i < internal; ++i) s.order[cursor[internal_level[i] - 1]++] = std::uint32_t(N + i);
    return s;
  }
  // Deadline of a node: the smallest level among its successors (sinks: D + 1).
  std::vector<std::uint32_t> deadline(internal, D + 1);  // internal nodes only: sources are not scheduled
  for (std::size_t i = 0; i < internal; ++i) {
    const auto& n = g.nodes[i];
    const std::uint32_t v = internal_level[i];
    for (std::uint32_t pred : {n.a, n.b})
      if (pred >= N) deadline[pred - N] = std::min(deadline[pred - N], v);
  }
  std::vector<std::vector<std::uint32_t>> by_level(std::size_t(D) + 1);
  for (std::size_t i = 0; i < internal; ++i) by_level[internal_level[i]].push_back(std::uint32_t(N + i));
  std::vector<std::vector<std::uint32_t>> pool(std::size_t(D) + 2);  // by deadline
  const std::uint64_t target = D ? (internal + D - 1) / D : 0;
  for (std::uint32_t t = 1; t <= D; ++t) {
    for (std::uint32_t id : by_level[t]) pool[deadline[id - N]].push_back(id);
    const std::size_t begin = s.order.size();
    // Urgent: a successor runs in phase t + 1.
    s.order.insert(s.order.end(), pool[t + 1].begin(), pool[t + 1].end());
    pool[t + 1].clear();
    // Fill up with deferrable nodes, earliest deadline first.
    for (std::uint32_t d = t + 2; d <= D + 1 && s.order.size() - begin < target; ++d) {
      auto& b = pool[d];
      while (!b.empty() && s.order.size() - begin < target) {
        s.order.push_back(b.back());
        b.pop_back();
      }
    }
    std::sort(s.order.begin() + std::ptrdiff_t(begin), s.order.end());
    s.phase_offsets[t] = s.order.size();
  }
  return s;
}

}  // namespace strata::mixture
