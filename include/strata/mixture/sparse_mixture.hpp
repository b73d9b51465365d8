#pragma once
/// @file
/// @brief Sparse mixtures over R^inf (paper §3, Eq. 1-3): a vector of (index, weight) pairs kept
/// sorted by index (§3.7: not a hash map). Weights are doubles; integer counts are exact in a
/// double up to 2^53, which is how the histogram mipmap keeps its rational weights exact.
#include <cstdint>
#include <span>
#include <vector>

namespace strata::mixture {

/// @brief One (index, weight) pair of a mixture.
struct SparseEntry {
  std::uint32_t index = 0;
  double weight = 0.0;
  bool operator==(const SparseEntry&) const = default;
};

/// @brief A mixture: its (index, weight) entries sorted by strictly increasing index, no zero weights.
class SparseMixture {
 public:
  SparseMixture() = default;
  /// @brief Takes entries in any order: sorts by index, sums duplicates, drops zero weights.
  /// Throws Error on a negative or non-finite weight.
  static SparseMixture from_entries(std::vector<SparseEntry> entries);
  /// @brief Entries already sorted by strictly increasing index with positive weights (not checked
  /// beyond a debug assertion).
  static SparseMixture from_sorted(std::vector<SparseEntry> entries);
  static SparseMixture from_sorted(std::span<const std::uint32_t> index, std::span<const double> weight);
  static SparseMixture unit(std::uint32_t index) { return from_sorted({SparseEntry{index, 1.0}}); }

  std::size_t nnz() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }
  std::span<const SparseEntry> entries() const { return entries_; }
  const SparseEntry& operator[](std::size_t i) const { return entries_[i]; }
  /// @brief The weight at `index` (0 if absent); binary search.
  double weight(std::uint32_t index) const;
  bool contains(std::uint32_t index) const;
  /// @brief Largest index with a non-zero weight (k-hat of the paper); requires !empty().
  std::uint32_t max_index() const { return entries_.back().index; }
  double total() const;  // l1 norm (weights are non-negative)

  /// @brief l1 normalisation: weights divided by total(); no-op on an empty mixture.
  void normalize();

  /// @brief this += s * o (sorted merge, O(nnz + o.nnz)).
  void add_scaled(const SparseMixture& o, double s);
  /// @brief (1 - w) a + w b, the linear interpolation of Eq. 5.
  static SparseMixture lerp(const SparseMixture& a, const SparseMixture& b, double w);
  /// @brief sum_i |a_i - b_i| over the union of supports.
  static double l1_distance(const SparseMixture& a, const SparseMixture& b);
  /// @brief <m, x>: the convex combination of dense data x (x.size() > max_index()).
  double dot(std::span<const double> x) const;

  bool operator==(const SparseMixture&) const = default;

 private:
  std::vector<SparseEntry> entries_;
};

}  // namespace strata::mixture
