#pragma once
/// @file
/// @brief Palette propagation (paper §3.4, §4): a float attribute vector per source (e.g. RGBA from a
/// transfer function) is interpolated through the Mixture Graph so that every node - and thus
/// every voxel of every mip level - gets its pre-filtered value. Phases of the schedule run in
/// order, the nodes of one phase in parallel (OpenMP, strata::thread_count()).
#include <cstdint>
#include <span>
#include <vector>

#include "strata/mixture/factorize.hpp"
#include "strata/mixture/schedule.hpp"

namespace strata::mixture {

/// @brief source_values: num_sources x channels (row per source). out: node_count x channels; rows
/// 0..num_sources-1 are copied, the rest computed as (1 - w) out[a] + w out[b].
/// Throws Error on size mismatches.
void propagate_palette(const MixtureGraph& g, const Schedule& schedule, std::span<const float> source_values, int channels,
                       std::span<float> out);
/// @brief The same, returning `out`.
std::vector<float> propagate_palette(const MixtureGraph& g, const Schedule& schedule,
                                     std::span<const float> source_values, int channels);

}  // namespace strata::mixture
