#pragma once
/// @file
/// @brief Mixture lookup table (paper §3.5, §5.2): the expected mixture mu over sources of every node
/// and its per-component uncertainty delta-mu, propagated from the sources (e_i, delta 0)
/// through the interpolations with the codebook's per-bin sigma as delta-w. Built phase by
/// phase along the schedule, nodes of a phase in parallel.
///
/// Error models for one interpolation mu = (1 - w) a + w b:
///   eq18    the paper's Eq. 18 as printed:
///           dmu_i = sqrt(mu_i^2 ((da_i/a_i)^2 + (db_i/b_i)^2 + 2 (dw/w)^2)),
///           a ratio term counting as 0 where its component is 0.
///   linear  first-order propagation of the same expression (Eq. 17 applied to it, with the
///           two occurrences of w correlated):
///           dmu_i^2 = (1 - w)^2 da_i^2 + w^2 db_i^2 + (b_i - a_i)^2 dw^2.
///           Unlike eq18 it does not blow up for small w (eq18 gives the component of a an
///           uncertainty of sqrt(2) (1 - w) dw / w).
#include <cstdint>
#include <span>
#include <vector>

#include "strata/mixture/factorize.hpp"
#include "strata/mixture/schedule.hpp"
#include "strata/mixture/sparse_mixture.hpp"

namespace strata::mixture {

/// @brief How delta-mu is propagated through an interpolation (see the file comment).
enum class ErrorModel : std::uint8_t { eq18, linear };

/// @brief Per node: the sorted source indices of its expected mixture, their mean weights and sigmas.
class MixtureLookup {
 public:
  /// @brief The table of every node of `g`, built phase by phase along `schedule`.
  static MixtureLookup build(const MixtureGraph& g, const Schedule& schedule, ErrorModel model = ErrorModel::eq18);

  std::uint64_t node_count() const { return length_.size(); }
  std::span<const std::uint32_t> index(std::uint32_t node) const { return {index_.data() + offset_[node], length_[node]}; }
  std::span<const double> mean_weights(std::uint32_t node) const { return {mean_.data() + offset_[node], length_[node]}; }
  std::span<const double> sigma(std::uint32_t node) const { return {sigma_.data() + offset_[node], length_[node]}; }
  SparseMixture mean(std::uint32_t node) const { return SparseMixture::from_sorted(index(node), mean_weights(node)); }
  std::uint64_t total_nnz() const { return index_.size(); }

  /// @brief Cache hints for expanding many nodes in a row (box queries): the lookup of a large volume
  /// spans gigabytes, so each node costs two dependent misses (its offset, then its entries).
  /// prefetch_node() asks for the offset and length; prefetch_entries(), issued a few nodes later
  /// when the offset has arrived, for the start of the entries.
  void prefetch_node(std::uint32_t node) const {
    __builtin_prefetch(offset_.data() + node);
    __builtin_prefetch(length_.data() + node);
  }
  void prefetch_entries(std::uint32_t node) const {
    const std::uint64_t o = offset_[node];
    __builtin_prefetch(index_.data() + o);
    __builtin_prefetch(mean_.data() + o);
    __builtin_prefetch(sigma_.data() + o);
  }

 private:
  std::vector<std::uint64_t> offset_;
  std::vector<std::uint32_t> length_;
  std::vector<std::uint32_t> index_;
  std::vector<double> mean_, sigma_;
};

/// @brief The reconstructed mixture of one voxel at any level.
SparseMixture reconstruct(const Factorization& f, const MixtureLookup& lookup, int level, std::int64_t x, std::int64_t y,
                          std::int64_t z);

/// @brief How far the graph's mixtures are from the mipmap's exact ones (l1 distance).
struct ErrorReport {
  double max_l1 = 0.0;          // max over all voxels of all levels of |H - reconstruction|_1
  double mean_l1 = 0.0;         // voxel-weighted mean
  std::uint32_t worst_mixture = 0;
  std::vector<double> level_max_l1;  // per level (empty when the mipmap's levels were released)
};
/// @brief Compares every distinct mixture of the mipmap with the lookup of its node.
ErrorReport measure_error(const HistogramMipmap& h, const Factorization& f, const MixtureLookup& lookup);

}  // namespace strata::mixture
