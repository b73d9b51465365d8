// The Mixture Graph bitstream (paper Table 1): header, node triples, 20-bit codebook.
// Layout: docs/format.md, "Codec mixture-graph".
#include "strata/mixture/graph_bitstream.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "strata/core/bitstream.hpp"
#include "strata/core/error.hpp"

namespace strata::mixture {

namespace {

constexpr int kCodeBits = 20;
constexpr std::uint32_t kCodeMax = (1u << kCodeBits) - 1u;
const double kCodeRoundingVariance = std::ldexp(1.0, -2 * (kCodeBits + 1)) / 3.0;

int ceil_log2(std::uint64_t n) {  // bits for values 0..n-1, at least 1
  int b = 1;
  while (b < 64 && (std::uint64_t(1) << b) < n) ++b;
  return b;
}

}  // namespace

std::vector<std::byte> write_graph_bitstream(const MixtureGraph& g, bool fractional, Extent resolution) {
  const std::uint64_t nodes = g.node_count();
  if (nodes > std::numeric_limits<std::uint32_t>::max()) throw Error("mixture graph: more than 2^32 - 1 nodes");
  const int bpn = ceil_log2(nodes);
  const int qb = g.codebook.bits;
  if (qb < 1 || qb > 16) throw Error("mixture graph: codebook bits must be 1..16");
  if (g.codebook.value.size() != (std::size_t(1) << qb) || g.codebook.sigma.size() != g.codebook.value.size())
    throw Error("mixture graph: codebook must have 2^bits values and sigmas");
  double smax = 0.0;
  for (double s : g.codebook.sigma) smax = std::max(smax, std::isfinite(s) ? s : 0.0);
  const float sigma_max = float(smax);
  BitWriter w;
  w.put(g.num_sources, 32);                                    // (1)
  w.put(fractional ? 1 : 0, 1);                                // (2)
  w.put(std::uint64_t(bpn - 1), 6);                            // (3) bits per node - 1
  w.put(std::bit_cast<std::uint32_t>(sigma_max), 32);          // (4) IEEE float
  w.put(std::uint64_t(resolution.x), 32);                      // (5)
  w.put(std::uint64_t(resolution.y), 32);
  w.put(std::uint64_t(resolution.z), 32);
  w.put(std::uint64_t(qb - 1), 4);                             // (6) bitrate - 1
  w.put(g.codebook.layout == WeightBins::uniform ? 1 : 0, 1);  // (6b) deviation: bin layout
  w.put(g.nodes.size(), bpn);                                  // (7)
  for (const InternalNode& n : g.nodes) {                      // (B)
    w.put(n.a, bpn);
    w.put(n.b, bpn);
    w.put(n.bin, qb);
  }
  for (std::size_t i = 0; i < g.codebook.value.size(); ++i) {  // (C)
    const double v = std::clamp(g.codebook.value[i], 0.0, 1.0);
    w.put(std::min<std::uint64_t>(kCodeMax, std::uint64_t(std::llround(v * double(1u << kCodeBits)))), kCodeBits);
    const double s = std::isfinite(g.codebook.sigma[i]) ? g.codebook.sigma[i] : 0.0;
    // Rounded up: a decoded sigma never claims more precision than the encoder measured.
    const std::uint64_t qs =
        sigma_max > 0.0f ? std::min<std::uint64_t>(kCodeMax, std::uint64_t(std::ceil(s / double(sigma_max) * kCodeMax))) : 0;
    w.put(qs, kCodeBits);
  }
  return w.take();
}

MixtureGraph read_graph_bitstream(std::span<const std::byte> bytes, const std::string& file, GraphHeader* out_header) {
  BitReader r(bytes, file, "mixture_graph ");
  GraphHeader h;
  h.num_sources = std::uint32_t(r.get(32, "#sources"));
  h.fractional = r.get(1, "fractional flag") != 0;
  h.bits_per_node = int(r.get(6, "bits per node")) + 1;
  h.sigma_max = std::bit_cast<float>(std::uint32_t(r.get(32, "sigma max")));
  h.resolution.x = std::int64_t(r.get(32, "resolution"));
  h.resolution.y = std::int64_t(r.get(32, "resolution"));
  h.resolution.z = std::int64_t(r.get(32, "resolution"));
  h.quant_bits = int(r.get(4, "quantization bitrate")) + 1;
  h.layout = r.get(1, "bin layout") ? WeightBins::uniform : WeightBins::symmetric;
  if (h.num_sources == 0) throw FormatError(file, "mixture_graph #sources", "must be at least 1");
  if (h.bits_per_node > 32) throw FormatError(file, "mixture_graph bits per node", "must be at most 32, got " + std::to_string(h.bits_per_node));
  if (!std::isfinite(h.sigma_max) || h.sigma_max < 0.0f) throw FormatError(file, "mixture_graph sigma max", "must be finite and >= 0");
  if (h.resolution.x < 1 || h.resolution.y < 1 || h.resolution.z < 1)
    throw FormatError(file, "mixture_graph resolution", "dimensions must be positive");
  h.internal_nodes = r.get(h.bits_per_node, "#internal nodes");
  const std::uint64_t nodes = std::uint64_t(h.num_sources) + h.internal_nodes;
  if (nodes > (std::uint64_t(1) << h.bits_per_node) || nodes > std::numeric_limits<std::uint32_t>::max())
    throw FormatError(file, "mixture_graph #internal nodes",
                      std::to_string(nodes) + " nodes do not fit " + std::to_string(h.bits_per_node) + " bits per node");
  const std::uint64_t bins = std::uint64_t(1) << h.quant_bits;
  const std::uint64_t need = r.position() + h.internal_nodes * std::uint64_t(2 * h.bits_per_node + h.quant_bits) +
                             bins * 2 * kCodeBits;
  if ((need + 7) / 8 != bytes.size())
    throw FormatError(file, "mixture_graph size",
                      "expected " + std::to_string((need + 7) / 8) + " bytes for " + std::to_string(h.internal_nodes) +
                          " internal nodes, found " + std::to_string(bytes.size()));
  MixtureGraph g;
  g.num_sources = h.num_sources;
  g.nodes.resize(std::size_t(h.internal_nodes));
  for (std::uint64_t i = 0; i < h.internal_nodes; ++i) {
    InternalNode& n = g.nodes[std::size_t(i)];
    n.a = std::uint32_t(r.get(h.bits_per_node, "node a"));
    n.b = std::uint32_t(r.get(h.bits_per_node, "node b"));
    n.bin = std::uint32_t(r.get(h.quant_bits, "node bin"));
    const std::uint64_t id = h.num_sources + i;
    if (n.a >= id || n.b >= id || n.a == n.b)
      throw FormatError(file, "mixture_graph node " + std::to_string(id),
                        "predecessors (" + std::to_string(n.a) + ", " + std::to_string(n.b) +
                            ") must be distinct earlier nodes");
  }
  g.codebook.bits = h.quant_bits;
  g.codebook.layout = h.layout;
  g.codebook.value.resize(std::size_t(bins));
  g.codebook.sigma.resize(std::size_t(bins));
  g.codebook.uses.assign(std::size_t(bins), 0);
  for (std::uint64_t i = 0; i < bins; ++i) {
    const std::uint64_t qv = r.get(kCodeBits, "codebook value");
    const std::uint64_t qs = r.get(kCodeBits, "codebook sigma");
    g.codebook.value[std::size_t(i)] = double(qv) / double(1u << kCodeBits);
    // The stored value is the code rounded to 2^-20: a weight error of up to 2^-21 that even a
    // bin of exact weights (sigma 0) carries, taken as uniform, variance (2^-21)^2 / 3.
    const double stored_sigma = double(qs) / double(kCodeMax) * double(h.sigma_max);
    g.codebook.sigma[std::size_t(i)] = std::sqrt(stored_sigma * stored_sigma + kCodeRoundingVariance);
  }
  if (out_header) *out_header = h;
  return g;
}

}  // namespace strata::mixture
