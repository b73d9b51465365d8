#pragma once
/// @file
/// @brief The "mixture_graph" section of a label file (byte layout: docs/format.md, "Codec mixture-graph").
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "strata/core/extent.hpp"
#include "strata/mixture/factorize.hpp"

namespace strata::mixture {

/// @brief The graph bitstream (paper Table 1 header, node triples, 20-bit codebook). `name` names the
/// input in errors. Decoded codebook values are the 20-bit quantised ones (uses are not stored).
struct GraphHeader {
  std::uint32_t num_sources = 0;
  bool fractional = false;
  int bits_per_node = 1;
  float sigma_max = 0.0f;
  Extent resolution;
  int quant_bits = 9;
  WeightBins layout = WeightBins::symmetric;
  std::uint64_t internal_nodes = 0;
};
/// @brief The section's bytes for graph `g`; throws Error for a graph the layout cannot hold.
std::vector<std::byte> write_graph_bitstream(const MixtureGraph& g, bool fractional, Extent resolution);
/// @brief The graph of a section's bytes (and its header when `header` is set); throws FormatError
/// naming `name` and the field for malformed bytes.
MixtureGraph read_graph_bitstream(std::span<const std::byte> bytes, const std::string& name,
                                  GraphHeader* header = nullptr);

}  // namespace strata::mixture
