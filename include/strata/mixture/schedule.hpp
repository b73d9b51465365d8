#pragma once
/// @file
/// @brief Topological levels of the Mixture Graph and the load-balanced evaluation schedule of
/// paper §3.4: sources have level 0, an internal node max(level(a), level(b)) + 1; the depth
/// is the largest level (= the number of synchronisation barriers).
#include <cstdint>
#include <span>
#include <vector>

#include "strata/mixture/factorize.hpp"

namespace strata::mixture {

/// @brief Level of every node (sources 0). One linear scan: predecessors come first.
std::vector<std::uint32_t> topological_levels(const MixtureGraph& g);
std::uint32_t topological_depth(const MixtureGraph& g);

/// @brief Internal nodes grouped into phases 1..depth; nodes within a phase are independent. A node
/// of level v whose earliest successor has level s may run in any phase v..s-1 (sinks: up to
/// depth). Balanced: each phase runs its urgent nodes (deadline now) and then, earliest
/// deadline first, deferred ones until it holds at least ceil(internal nodes / depth).
/// Unbalanced: phase = level.
struct Schedule {
  std::uint32_t depth = 0;
  std::vector<std::uint32_t> order;          // node ids, phase by phase, ascending within one
  std::vector<std::uint64_t> phase_offsets;  // size depth + 1; phase p (1-based) is
                                             // order[phase_offsets[p-1], phase_offsets[p])
  std::span<const std::uint32_t> phase(std::uint32_t p) const {
    return {order.data() + phase_offsets[p - 1], std::size_t(phase_offsets[p] - phase_offsets[p - 1])};
  }
};
/// @brief The schedule of `g`, balanced as above unless `balanced` is false.
Schedule make_schedule(const MixtureGraph& g, bool balanced = true);

}  // namespace strata::mixture
