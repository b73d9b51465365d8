#pragma once
/// @file
/// @brief Greedy factorisation of a histogram mipmap into the Mixture Graph.
///
/// Implements paper 4 §3.2-3.3 (Eq. 5-7, 11-14) with the two-stage search and the weight
/// symmetry of §3.7. Every mixture becomes a chain of 2-element interpolations: internal node
/// (a, b, bin) = (1 - w) node_a + w node_b, w the codebook value of `bin`. Node ids are the
/// sources 0..N-1 followed by the internal nodes in creation order, and predecessors always
/// have smaller ids than the node, so the list is a DAG in topological order.
/// Design notes: docs/mixture-graph.md#factorisation
#include <cstdint>
#include <filesystem>
#include <string_view>
#include <utility>
#include <vector>

#include "strata/core/progress.hpp"
#include "strata/mixture/histogram_mipmap.hpp"

namespace strata::mixture {

/// @brief How the greedy search scores a pair of node ids (docs/mixture-graph.md#pair-scores).
enum class PairScore : std::uint8_t {
  occurrence,  // phi1 (Eq. 11-12): voxels holding both ids
  reduction,   // phi2 (Eq. 13-14): voxels holding both ids, weighted by nnz - 1 (2 if nnz = 2)
  reuse,       // merges saved by bin sharing first (mixtures touched - distinct bins), then phi1
};
/// @brief "occurrence", "reduction" or "reuse". Throws Error for a value outside the enum.
std::string_view pair_score_name(PairScore s);
/// @brief The paper's name: "max-occurrence", "max-reduction" or "reuse". Throws as above.
std::string_view strategy_name(PairScore s);
/// @brief Accepts any of the names above and "phi1" / "phi2"; throws Error otherwise.
PairScore parse_pair_score(std::string_view name);

/// @brief How interpolation weights are binned; 2^bits bins (bits per node) either way
/// (docs/mixture-graph.md#weight-bins).
enum class WeightBins : std::uint8_t {
  // Default. The symmetry (i, j, w) == (j, i, 1 - w) of §3.7: the weight goes on the lighter
  // predecessor b (ties: a < b), so w is in (0, 0.5]; bins are centred on the multiples of
  // 2^-(bits+1), twice the precision of `uniform` for the same bits.
  symmetric,
  // The paper's layout: uniform bins [q, q + 1) / 2^bits over (0, 1), canonical a < b
  // (w = weight of the larger id; swapping the pair mirrors the bin).
  uniform,
};
/// @brief "symmetric" or "uniform".
std::string_view weight_bins_name(WeightBins b);
/// @brief The layout named `name` (as weight_bins_name spells it); throws Error otherwise.
WeightBins parse_weight_bins(std::string_view name);

/// @brief Options of factorize().
struct FactorOptions {
  PairScore score = PairScore::reduction;
  int bits = 9;                        // 2^bits weight bins; 1..16
  WeightBins bins = WeightBins::symmetric;
  std::uint32_t tau = 3;               // two-stage threshold of §3.7; <= 1 = one stage
  // Mixtures with more ids than this (at levels >= 1) are built from their children's nodes
  // (Eq. 4; docs/mixture-graph.md#dense-mixtures). 0 = greedy for every mixture (the paper's way).
  std::uint32_t dense_threshold = 8;
  // When set, the mipmap overloads park the mip levels' ids in an unnamed temporary file in
  // this folder during the greedy search (whose pair tables are then the largest structure),
  // so peak memory is the larger of the two rather than their sum. Same result either way.
  std::filesystem::path park_dir;
};

// Weight bins. Pure functions, safe from any thread; `bits` is not checked (use 1..16).
/// @brief Bin of a weight: symmetric: w in (0, 0.5], round(w 2^(bits+1)) - 1 clamped to
/// [0, 2^bits - 1]; uniform: w in (0, 1), floor(w 2^bits) clamped likewise.
std::uint32_t quantize_weight(double w, int bits, WeightBins layout = WeightBins::symmetric);
/// @brief Centre of bin q: (q + 1) / 2^(bits+1) symmetric, (q + 0.5) / 2^bits uniform.
double bin_center(std::uint32_t q, int bits, WeightBins layout = WeightBins::symmetric);
/// @brief [lo, hi) covered by bin q (symmetric: the first bin starts at 0, the last ends at 0.5).
std::pair<double, double> bin_range(std::uint32_t q, int bits, WeightBins layout = WeightBins::symmetric);
/// @brief Uniform layout only: the bin of 1 - w for w in bin q (exact except on bin edges).
constexpr std::uint32_t mirror_bin(std::uint32_t q, int bits) { return (1u << bits) - 1u - q; }

/// @brief The canonical node for merging x (mass mx) with y (mass my): (1 - w) a + w b.
struct Interpolation {
  std::uint32_t a = 0, b = 0;
  double w = 0.0;  // exact weight of b
  std::uint32_t bin = 0;
};
/// @brief Orients the merge of x and y as `layout` requires (symmetric: b is the lighter one,
/// ties a < b; uniform: a < b) and bins its exact weight. Pure function.
Interpolation orient(std::uint32_t x, std::uint32_t y, double mx, double my, int bits, WeightBins layout);

/// @brief One internal node of the graph.
struct InternalNode {
  std::uint32_t a = 0, b = 0;  // predecessors: (1 - w) a + w b, w = codebook.value[bin]
  std::uint32_t bin = 0;       // symmetric: b is the lighter one; uniform: a < b
  bool operator==(const InternalNode&) const = default;
};

/// @brief Scalar quantiser of the interpolation weights (docs/mixture-graph.md#codebook).
///
/// Per bin, over all uses (a use = one voxel of H whose factorisation applies the node, i.e.
/// weighted by multiplicity): the code value, the mean of the member weights; and sigma, the
/// uncertainty of a weight decoded as that value, which box queries propagate (Eq. 17-18):
/// sigma = max(empirical standard deviation, largest |w - value| / sqrt(3)). Empty bins hold
/// the bin centre and sigma 0.
struct Codebook {
  int bits = 9;
  WeightBins layout = WeightBins::symmetric;
  std::vector<double> value;        // per bin: code value
  std::vector<double> sigma;        // per bin: uncertainty of the code value
  std::vector<std::uint64_t> uses;  // per bin: uses
  std::uint32_t bins() const { return std::uint32_t(value.size()); }
};

/// @brief The Mixture Graph: sources, internal nodes in topological order and the codebook.
/// Plain data; the accessors do not check ids (node(), weight() and sigma() need an internal
/// node id). Concurrent reads are safe.
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
/// factorize() runs it on its result in debug builds. Reads only: safe from any thread.
void validate(const MixtureGraph& g);

/// @brief Figures of one factorisation.
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

/// @brief The result of factorize(): the graph and the node of every mixture and voxel.
struct Factorization {
  MixtureGraph graph;
  std::vector<std::uint32_t> node_of_mixture;  // per mixture table id
  std::vector<MipLevel> levels;                // per voxel node ids; level 0 = source ids
  FactorStats stats;
};

// factorize(): all overloads throw Error when options.bits is not in 1..16 or the graph would
// need more than 2^32 - 1 nodes; in debug builds a broken invariant throws too (validate(),
// STRATA_DEBUG_CHECK). The greedy search runs on the calling thread and reports its merges to
// `progress` as the task "factorize"; the mipmap overloads remap the id arrays on
// strata::thread_count() OpenMP threads. No state is kept between calls: calls on different
// inputs (each with its own progress sink, or the silent one) may run concurrently.

/// @brief Factorises every mixture of the mipmap; `levels` gets per-voxel node ids (a copy).
Factorization factorize(const HistogramMipmap& h, const FactorOptions& options = {},
                        ProgressSink& progress = silent_progress());
/// @brief Same, but consumes the mipmap and remaps its id arrays in place (no second copy).
Factorization factorize(HistogramMipmap&& h, const FactorOptions& options = {},
                        ProgressSink& progress = silent_progress());
/// @brief Factorises the mixtures (nnz >= 2) of a bare table greedily (no hierarchy, so no
/// dense shortcut); multiplicity 0 counts as 1. `levels` stays empty.
Factorization factorize(const MixtureTable& table, const FactorOptions& options = {},
                        ProgressSink& progress = silent_progress());

}  // namespace strata::mixture
