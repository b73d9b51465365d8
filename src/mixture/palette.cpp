#include "strata/mixture/palette.hpp"

#include <string>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::mixture {

void propagate_palette(const MixtureGraph& g, const Schedule& schedule, std::span<const float> source_values, int channels,
                       std::span<float> out) {
  if (channels <= 0) throw Error("palette: channels must be positive");
  const std::size_t C = std::size_t(channels);
  if (source_values.size() != std::size_t(g.num_sources) * C)
    throw Error("palette: expected " + std::to_string(std::size_t(g.num_sources) * C) + " source values (" +
                std::to_string(g.num_sources) + " sources x " + std::to_string(channels) + " channels), got " +
                std::to_string(source_values.size()));
  if (out.size() != g.node_count() * C)
    throw Error("palette: output holds " + std::to_string(out.size()) + " values, the graph needs " +
                std::to_string(g.node_count() * C));
  if (schedule.order.size() != g.nodes.size()) throw Error("palette: schedule does not match the graph");
  std::copy(source_values.begin(), source_values.end(), out.begin());
  // Code values as float once, so the inner loop is a plain lerp.
  std::vector<float> w(g.codebook.value.begin(), g.codebook.value.end());
  float* o = out.data();
  const int nt = thread_count();
  // A phase is one fork/join. One thread interpolates ~250 M RGBA nodes/s, so a phase of
  // fewer than ~256k nodes finishes in about the time a join costs on a busy machine (a
  // descheduled worker stalls it for a whole time slice): such phases run on the caller.
  const std::int64_t parallel_min_values = std::int64_t(1) << 20;
  for (std::uint32_t p = 1; p <= schedule.depth; ++p) {
    const auto phase = schedule.phase(p);
    const std::int64_t n = std::int64_t(phase.size());
#pragma omp parallel for num_threads(nt) schedule(static) if (n * std::int64_t(C) >= parallel_min_values)
    for (std::int64_t i = 0; i < n; ++i) {
      const std::uint32_t id = phase[std::size_t(i)];
      const InternalNode& node = g.node(id);
      const float t = w[node.bin];
      const float* va = o + std::size_t(node.a) * C;
      const float* vb = o + std::size_t(node.b) * C;
      float* vo = o + std::size_t(id) * C;
      for (std::size_t c = 0; c < C; ++c) vo[c] = (1.0f - t) * va[c] + t * vb[c];
    }
  }
}

std::vector<float> propagate_palette(const MixtureGraph& g, const Schedule& schedule,
                                     std::span<const float> source_values, int channels) {
  std::vector<float> out(g.node_count() * std::size_t(std::max(channels, 0)));
  propagate_palette(g, schedule, source_values, channels, out);
  return out;
}

}  // namespace strata::mixture
