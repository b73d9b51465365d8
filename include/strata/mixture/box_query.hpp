#pragma once
/// @file
/// @brief Histograms of source labels over axis-aligned boxes of an encoded label volume.
///
/// Implements the box queries of paper 4 §3.5-3.6 (Fig. 6, Table 4): per source id the expected
/// voxel count in the box and its standard deviation (Eq. 17). Four methods: `naive` scans
/// level 0 (exact, sigma 0 for label input); `footprint` assembles the box from mip-aligned
/// cubes, one sample each; `hybrid` (the default) does the same but scans the thin shell at the
/// box's faces at level 0 where that is cheaper; `coarse` samples one level with a bounded
/// number of cells and widens sigma for the cells the box cuts.
/// Design notes: docs/mixture-graph.md#box-queries
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "strata/core/extent.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/node_grid.hpp"

namespace strata::mixture {

/// @brief How a box histogram is computed (see the file comment).
enum class QueryMethod : std::uint8_t { hybrid, footprint, naive, coarse };
/// @brief "hybrid", "footprint", "naive" or "coarse".
std::string_view query_method_name(QueryMethod m);
/// @brief The method named `name` (as query_method_name spells it); throws Error otherwise.
QueryMethod parse_query_method(std::string_view name);

/// @brief One source's share of a box.
struct BoxCount {
  std::uint32_t source = 0;  // dense source id (LabelMap::value(source) = original label)
  double count = 0.0;        // expected voxels
  double sigma = 0.0;        // standard deviation of the count
};

/// @brief The answer to one box query, with the work it took.
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

/// @brief Method and tuning of a box query.
struct QueryOptions {
  QueryMethod method = QueryMethod::hybrid;
  // Hybrid cost model, in units of scanning one level-0 voxel (docs/mixture-graph.md#hybrid-cost-model).
  double sample_cost = 6.0;  // per sample of a level >= 1
  double row_cost = 8.0;     // per row of at most 16 ids read (longer rows: 1)
  double box_cost = 40.0;  // per box of the plan (one decode call)
  int threads = 0;  // naive only; 0 = strata::thread_count()
  std::uint64_t max_samples = 4096;  // coarse only: cells sampled at most (>= 1)
};

/// @brief One box of a footprint/hybrid plan: the level-`level` voxels `cells` (coordinates of
/// that level), covering the level-0 voxels `covered` (clipped at the volume border).
struct FootprintBox {
  int level = 0;
  Box cells;
  Box covered;
};

/// @brief Mip-aligned pieces of [lo, hi) on an axis of length `dim` with levels 0..max_level:
/// (start, log2 size) pairs in order, each the largest aligned piece that fits. A piece may run
/// past `dim` only when hi == dim and dim - start is a power of two. Throws Error unless
/// 0 <= lo < hi <= dim.
std::vector<std::pair<std::int64_t, int>> aligned_pieces(std::int64_t lo, std::int64_t hi, std::int64_t dim,
                                                          int max_level);

/// @brief Box histogram queries over one encoded label volume.
///
/// Thread safety: every method is const and may be called concurrently from several threads.
/// Each calling thread accumulates into its own thread-local buffers (one entry per source,
/// kept for the thread's lifetime); the grid and lookup are only read.
class BoxQuery {
 public:
  /// @brief Keeps references: `grid` and `lookup` must outlive the query object and stay
  /// unchanged. Throws Error when the grid has no levels or its levels are not the full mip
  /// chain of level 0.
  BoxQuery(const NodeGrid& grid, const MixtureLookup& lookup, std::uint32_t num_sources);

  /// @brief The histogram of `box` (level-0 coordinates) by `options.method`. Counts are in
  /// ascending source order and sum to the box volume up to rounding. Throws Error when the
  /// box is empty or not inside level 0 (coarse: also when max_samples is 0).
  BoxHistogram run(const Box& box, const QueryOptions& options = {}) const;
  /// @brief Exact level-0 scan; parallel over z-slices on `threads` OpenMP threads (0 =
  /// strata::thread_count(), at most one per slice) when the box holds at least 32768 voxels in
  /// two or more slices. Throws as run().
  BoxHistogram naive(const Box& box, int threads = 0) const;
  BoxHistogram footprint(const Box& box) const { return run(box, {QueryMethod::footprint}); }
  BoxHistogram hybrid(const Box& box) const { return run(box, {QueryMethod::hybrid}); }
  /// @brief Samples every cell of coarse_level(box, max_samples) that meets the box, weighted by
  /// the voxels it shares with the box; exact (a level-0 scan) when that level is 0. Throws as
  /// run(), and when max_samples is 0.
  BoxHistogram coarse(const Box& box, std::uint64_t max_samples = 4096) const;
  /// @brief The finest level whose cells meeting `box` number at most `max_samples` (the top
  /// level when none does; 0 when even level-0 voxels fit). Throws as coarse().
  int coarse_level(const Box& box, std::uint64_t max_samples) const;

  /// @brief The plan of a footprint query, or of a hybrid one when options.method is hybrid
  /// (tests and the --explain output). Throws as run().
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
