#pragma once
// Histograms over axis-aligned boxes of an encoded label volume (paper §3.5-3.6, Fig. 6,
// Table 4): per source id the expected voxel count and its standard deviation.
//
// Methods
//   naive      scans level 0 (node ids = source ids for label input: exact, sigma 0), z-slices
//              in parallel (OpenMP, strata::thread_count()), run-length + hash accumulation.
//   footprint  footprint assembly: each 1D range is cut into mip-aligned pieces [p, p + 2^k)
//              (p a multiple of 2^k), the tensor product of the pieces gives boxes, and each box
//              is tessellated by cubes of side 2^m = its smallest extent - one sample of level m
//              per cube, weighted by the voxels the sample really covers. A range ending at the
//              volume's far border may use a level-k piece that runs past it when the real rest
//              (dim - start) is a power of two: that border voxel has a single chain of children
//              down to a full voxel, so its mixture is exactly the histogram of its real support
//              and its samples are weighted by that true support volume (a power-of-two volume
//              is then one sample of the top level). Other border voxels are never sampled: Eq. 4
//              averages the children with equal weights (N = child count), so a voxel whose
//              children have unequal supports (e.g. 64 and 36) is not its support's histogram.
//   hybrid     (default) the same boxes, but each box picks the level (0..m) with the least
//              estimated cost: thin boxes next to the query's faces (the level-0 boundary shell
//              that dominates small queries) are scanned at level 0, the interior is sampled.
//   coarse     bounded cost for any box: every cell of one level m (the finest whose cells
//              meeting the box number at most QueryOptions::max_samples) is sampled once,
//              weighted by the voxels it shares with the box. A cell the box covers only in
//              part (n of its N voxels) holds c = N mu_s voxels of label s somewhere: the box
//              gets between max(0, n - (N - c)) and min(n, c) of them; the estimate's error is
//              taken as uniform over that range (its second moment about the estimate), and a
//              label's errors over the partly covered cells add up as fully correlated (labels
//              are spatially coherent: a face cuts neighbouring cells alike). Counts still sum
//              to the box volume. Near-whole boxes
//              whose faces miss coarse cell boundaries cost O(surface) voxels exactly; this
//              answers them from a few thousand samples.
// Accumulation: samples go into a flat hash per node id (weight sum W and sum of squared
// weights W2); every distinct node is expanded through the MixtureLookup once:
//   count_s += W mu_s / sum(mu),  var_s += W2 sigma_s^2
// (samples treated as independent, Eq. 17). The mean is renormalised per node, so counts sum to
// the box volume to rounding. Level-0 source ids go straight to the result (exact).
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "strata/core/extent.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/node_grid.hpp"

namespace strata::mixture {

enum class QueryMethod : std::uint8_t { hybrid, footprint, naive, coarse };
std::string_view query_method_name(QueryMethod m);  // "hybrid", "footprint", "naive", "coarse"
QueryMethod parse_query_method(std::string_view name);  // throws Error

struct BoxCount {
  std::uint32_t source = 0;  // dense source id (LabelMap::value(source) = original label)
  double count = 0.0;        // expected voxels
  double sigma = 0.0;        // standard deviation of the count
};

struct BoxHistogram {
  Box box;
  std::vector<BoxCount> counts;      // ascending source id, count > 0
  std::uint64_t fetches = 0;         // node ids read (level-0 voxels scanned + samples)
  std::uint64_t level0_voxels = 0;   // of those, at level 0
  std::uint64_t samples = 0;         // of those, at levels >= 1
  std::uint64_t pieces = 0;          // boxes of the footprint (tensor product of 1D pieces)
  std::uint64_t distinct_nodes = 0;  // internal nodes expanded through the lookup
  double total() const;              // sum of counts
  const BoxCount* find(std::uint32_t source) const;  // binary search; nullptr if absent
};

struct QueryOptions {
  QueryMethod method = QueryMethod::hybrid;
  // hybrid cost model, relative to scanning one level-0 voxel: a sample of level >= 1 (hash
  // update + share of the lookup expansion). A box of level-m cubes goes to level l with the
  // least (voxels of level l) * (l == 0 ? 1 : sample_cost) + (rows of level l) * row_cost.
  double sample_cost = 6.0;
  // ... plus per row of ids read (a cache line fetch on a linear id layout: the x faces of the
  // shell read one short row per (y, z)).
  double row_cost = 8.0;
  double box_cost = 40.0;  // per box of the plan (one decode call)
  // A box whose plan costs more than scanning it whole at level 0 is scanned whole.
  int threads = 0;  // naive only; 0 = strata::thread_count()
  std::uint64_t max_samples = 4096;  // coarse only: cells sampled at most (>= 1)
};

// One box of the footprint: level-`level` voxels [lo, hi) of that level (coordinates of the
// level), covering level-0 voxels `covered` (clipped at the volume border).
struct FootprintBox {
  int level = 0;
  Box cells;
  Box covered;
};

// Mip-aligned pieces of [lo, hi) on an axis of length `dim` with levels 0..max_level: (start,
// log2 size) pairs in order. A piece may run past `dim` only when hi == dim.
std::vector<std::pair<std::int64_t, int>> aligned_pieces(std::int64_t lo, std::int64_t hi, std::int64_t dim,
                                                          int max_level);

class BoxQuery {
 public:
  // Keeps references: grid and lookup must outlive the query object. Thread-safe (const).
  BoxQuery(const NodeGrid& grid, const MixtureLookup& lookup, std::uint32_t num_sources);

  // Throws Error when the box is empty or not inside level 0.
  BoxHistogram run(const Box& box, const QueryOptions& options = {}) const;
  BoxHistogram naive(const Box& box, int threads = 0) const;
  BoxHistogram footprint(const Box& box) const { return run(box, {QueryMethod::footprint}); }
  BoxHistogram hybrid(const Box& box) const { return run(box, {QueryMethod::hybrid}); }
  BoxHistogram coarse(const Box& box, std::uint64_t max_samples = 4096) const;
  // The level the coarse method samples for `box` (0 when even level-0 voxels fit the budget).
  int coarse_level(const Box& box, std::uint64_t max_samples) const;

  // The plan of a footprint/hybrid query (for tests and the --explain output).
  std::vector<FootprintBox> plan(const Box& box, const QueryOptions& options = {}) const;

  const NodeGrid& grid() const { return grid_; }
  const MixtureLookup& lookup() const { return lookup_; }
  std::uint32_t num_sources() const { return num_sources_; }

 private:
  void check(const Box& box) const;

  const NodeGrid& grid_;
  const MixtureLookup& lookup_;
  std::uint32_t num_sources_ = 0;
  std::vector<Extent> dims_;
};

}  // namespace strata::mixture
