#pragma once
// Greedy factorisation of the histogram mipmap into 2-element interpolations (paper §3.2-3.3,
// Eq. 5-7, 11-14, §3.7), producing the Mixture Graph: a DAG whose nodes are the sources
// 0..N-1 followed by internal nodes (a, b, bin) = (1 - w) node_a + w node_b, w the code value
// of `bin`; predecessors always come earlier in the list (a, b < the node's id).
//
// Design (see docs in factorize.cpp for details):
// * The greedy works on DISTINCT mixtures weighted by their voxel multiplicity. Each step
//   picks the best pair (i, j) and factors ALL its occurrences (Eq. 7); with tau >= 2, only
//   mixtures with nnz > tau vote until none is left, then all vote (§3.7). Scores are kept in
//   incremental structures - pair -> stats hash map, a lazily invalidated max-heap and
//   postings (node -> mixtures containing it) - so a step touches only the mixtures holding
//   the pair, O(nnz) per mixture (O(nnz^2) for phi2 when the mixture's nnz term changes).
// * Weights are quantised into 2^bits bins DURING factorisation (see WeightBins), so two
//   merges of the same pair with the same bin become one node. A pair never reappears after
//   its step, so all sharing happens within a step: the number of nodes a step creates is
//   the number of distinct bins among the mixtures it touches. Every score therefore breaks
//   ties by the merges it saves ("saved" = mixtures touched - distinct bins) and then by the
//   smallest combined weight (Huffman-like, which also minimises the error bound); this is
//   what makes the paper's worked examples (Fig. 2, Fig. 4) come out as drawn.
// * Dense mixtures (nnz > dense_threshold; coarse levels only) are not factorised over
//   sources. Each is Eq. 4 itself: the average of its <= 8 children, whose nodes already
//   exist, merged smallest-count-first (<= 7 nodes instead of nnz - 1). This keeps the huge
//   top-level pair sets (C(10^4, 2) pairs for one voxel, whose phi2 terms would all change
//   at every merge) out of the greedy, and lowers both time and node count. Its error is at
//   most the worst child's plus that of the <= 7 interpolations.
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "strata/core/progress.hpp"
#include "strata/mixture/histogram_mipmap.hpp"

namespace strata::mixture {

enum class PairScore : std::uint8_t {
  occurrence,  // phi1 (Eq. 11-12): voxels holding both ids
  reduction,   // phi2 (Eq. 13-14): voxels holding both ids, weighted by nnz - 1 (2 if nnz = 2)
  reuse,       // merges saved by bin sharing first (mixtures touched - distinct bins), then phi1
};
std::string_view pair_score_name(PairScore s);  // "occurrence", "reduction", "reuse"
std::string_view strategy_name(PairScore s);    // the paper's: "max-occurrence", "max-reduction", "reuse"
// Accepts any of the names above and "phi1" / "phi2"; throws Error otherwise.
PairScore parse_pair_score(std::string_view name);

// How interpolation weights are binned; 2^bits bins (bits per node) either way.
enum class WeightBins : std::uint8_t {
  // Default. The interpolation symmetry of §3.7, (i, j, w) == (j, i, 1 - w), applied when the
  // node is made: a node always puts the weight on its LIGHTER predecessor b (ties: a < b),
  // so w is in (0, 0.5] and the bins cover half the range - twice the precision for the same
  // bits; the order of (a, b) carries the extra bit. Bins are centred on the multiples of
  // 2^-(bits+1), where the dyadic weights of the fine mip levels (1/2, 3/8, 5/64 ...) fall,
  // so bin means stay central (with edge-aligned bins they pile up on an edge and the rest of
  // the bin sees almost a full bin width of error).
  symmetric,
  // The paper's layout: uniform bins [q, q + 1) / 2^bits over (0, 1), canonical a < b
  // (w = weight of the larger id; swapping the pair mirrors the bin).
  uniform,
};
std::string_view weight_bins_name(WeightBins b);  // "symmetric", "uniform"
WeightBins parse_weight_bins(std::string_view name);

struct FactorOptions {
  PairScore score = PairScore::reduction;
  int bits = 9;                        // 2^bits weight bins; 1..16
  WeightBins bins = WeightBins::symmetric;
  std::uint32_t tau = 3;               // two-stage threshold of §3.7; <= 1 = one stage
  // Mixtures with more ids than this (at levels >= 1) are built from their children's nodes.
  // 8 = the most children a voxel has: above it the <= 7 child merges never need more
  // interpolations than the nnz - 1 of factoring over sources. 0 = greedy for every mixture
  // (the paper's way; phi2 then costs O(nnz^2) per merge of the top mixtures - minutes).
  std::uint32_t dense_threshold = 8;
};

// Bin of a weight: symmetric: w in (0, 0.5], round(w 2^(bits+1)) - 1 clamped to
// [0, 2^bits - 1]; uniform: w in (0, 1), floor(w 2^bits) clamped likewise.
std::uint32_t quantize_weight(double w, int bits, WeightBins layout = WeightBins::symmetric);
double bin_center(std::uint32_t q, int bits, WeightBins layout = WeightBins::symmetric);
// [lo, hi) covered by bin q (symmetric: the first bin starts at 0, the last ends at 0.5).
std::pair<double, double> bin_range(std::uint32_t q, int bits, WeightBins layout = WeightBins::symmetric);
// uniform layout only: the bin of 1 - w for w in bin q (exact except on bin edges).
constexpr std::uint32_t mirror_bin(std::uint32_t q, int bits) { return (1u << bits) - 1u - q; }

// The canonical node for merging x (mass mx) with y (mass my): (1 - w) a + w b.
struct Interpolation {
  std::uint32_t a = 0, b = 0;
  double w = 0.0;  // exact weight of b
  std::uint32_t bin = 0;
};
Interpolation orient(std::uint32_t x, std::uint32_t y, double mx, double my, int bits, WeightBins layout);

struct InternalNode {
  std::uint32_t a = 0, b = 0;  // predecessors: (1 - w) a + w b, w = codebook.value[bin]
  std::uint32_t bin = 0;       // symmetric: b is the lighter one; uniform: a < b
  bool operator==(const InternalNode&) const = default;
};

// Scalar quantiser of the interpolation weights: per bin the mean of the member weights (the code
// value) and the uncertainty of a weight decoded as that value, both over all uses (a use = one
// voxel of H whose factorisation applies the node; i.e. weighted by multiplicity). Empty bins:
// the centre, sigma 0.
//
// sigma is what box queries propagate (paper Eq. 17-18), and it must hold for every node, not
// just on average: a bin's uses are mostly the exact dyadic weights of the fine levels, so
// their empirical standard deviation is tiny, while the rarer weights of the same bin sit up
// to half a bin away and every voxel of such a node carries that whole deviation. So
// sigma = max(empirical sigma, largest |w - value| / sqrt(3)): at least the spread of a weight
// uniform within +- the largest deviation seen in the bin.
struct Codebook {
  int bits = 9;
  WeightBins layout = WeightBins::symmetric;
  std::vector<double> value;
  std::vector<double> sigma;
  std::vector<std::uint64_t> uses;
  std::uint32_t bins() const { return std::uint32_t(value.size()); }
};

class MixtureGraph {
 public:
  std::uint32_t num_sources = 0;
  std::vector<InternalNode> nodes;  // node id = num_sources + index
  Codebook codebook;

  std::uint64_t node_count() const { return std::uint64_t(num_sources) + nodes.size(); }
  bool is_source(std::uint32_t id) const { return id < num_sources; }
  const InternalNode& node(std::uint32_t id) const { return nodes[id - num_sources]; }
  double weight(std::uint32_t id) const { return codebook.value[node(id).bin]; }
  double sigma(std::uint32_t id) const { return codebook.sigma[node(id).bin]; }
};

/// @brief Checks the Mixture Graph's invariants and throws Error naming the first violation:
/// every internal node has two distinct predecessors that come earlier (the node list is in
/// topological order, so the graph is acyclic), every bin index is < 2^bits, and every codebook
/// weight lies in its layout's range (symmetric (0, 0.5], uniform (0, 1)) with a finite sigma >= 0.
/// factorize() runs it on its result in debug builds.
void validate(const MixtureGraph& g);

struct FactorStats {
  std::uint64_t nodes = 0;             // including sources
  std::uint64_t internal_nodes = 0;
  std::uint64_t input_pairs = 0;       // sum of C(nnz, 2) over the distinct mixtures
  std::uint64_t greedy_mixtures = 0;   // distinct mixtures factored by the greedy search
  std::uint64_t dense_mixtures = 0;    // distinct mixtures factored via their children
  std::uint64_t steps = 0;             // pairs chosen
  std::uint64_t merges = 0;            // interpolations applied to distinct mixtures
  std::uint64_t reused = 0;            // of those, how many found their node already made
  std::uint32_t depth = 0;             // topological depth
  double seconds = 0.0;
};

struct Factorization {
  MixtureGraph graph;
  std::vector<std::uint32_t> node_of_mixture;  // per mixture table id
  std::vector<MipLevel> levels;                // per voxel node ids; level 0 = source ids
  FactorStats stats;
};

// Factorises every mixture of the mipmap; `levels` gets per-voxel node ids (a copy).
Factorization factorize(const HistogramMipmap& h, const FactorOptions& options = {},
                        ProgressSink& progress = silent_progress());
// Same, but consumes the mipmap and remaps its id arrays in place (no second copy).
Factorization factorize(HistogramMipmap&& h, const FactorOptions& options = {},
                        ProgressSink& progress = silent_progress());
// Factorises the mixtures (nnz >= 2) of a bare table greedily (no hierarchy, so no dense
// shortcut); multiplicity 0 counts as 1. `levels` stays empty.
Factorization factorize(const MixtureTable& table, const FactorOptions& options = {},
                        ProgressSink& progress = silent_progress());

}  // namespace strata::mixture
