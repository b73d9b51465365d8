#pragma once
/// @file
/// @brief A table of DISTINCT mixtures over source ids, stored CSR (one index and one mass array),
/// with hash-consing (intern) and per-mixture multiplicity (how many voxels of the histogram
/// mipmap, over all levels, hold it).
///
/// Exact arithmetic: in an `integral` table each mixture is stored in canonical rational form,
/// i.e. integer counts (held in doubles, exact below 2^53) divided by their gcd; the weight of
/// index i is mass_i / total. Single-label inputs stay integral at every mip level (child
/// counts per axis are 1 or 2, so every denominator is a power of two), which makes the
/// mipmap exact and makes equal normalised mixtures share one entry regardless of where they
/// occur. A non-integral (fractional-input) table stores l1-normalised double weights.
///
/// Ids 0..num_sources-1 are always the unit mixtures e_0..e_{N-1}, so level-0 mixture ids of
/// a single-label volume ARE its source ids.
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "strata/mixture/sparse_mixture.hpp"

namespace strata::mixture {

/// @brief The table itself (see the file comment).
class MixtureTable {
 public:
  static constexpr std::uint64_t kNoVoxel = std::numeric_limits<std::uint64_t>::max();

  MixtureTable() = default;
  MixtureTable(std::uint32_t num_sources, bool integral);

  std::uint32_t num_sources() const { return num_sources_; }
  bool integral() const { return integral_; }
  std::uint32_t size() const { return std::uint32_t(total_.size()); }

  /// @brief Returns the id of the mixture (index, mass), inserting it if new; the input must already
  /// be canonical (see canonicalize). `level`/`voxel` record where a new mixture first occurs.
  std::uint32_t intern(std::span<const std::uint32_t> index, std::span<const double> mass, std::uint64_t hash,
                       int level, std::uint64_t voxel);
  std::uint32_t intern(std::span<const std::uint32_t> index, std::span<const double> mass, int level = 0,
                       std::uint64_t voxel = kNoVoxel) {
    return intern(index, mass, hash_of(index, mass), level, voxel);
  }

  /// @brief Canonical form of sorted, duplicate-free entries with positive masses, in place: integral
  /// tables divide integer masses by their gcd, fractional tables divide by the sum.
  static void canonicalize(std::span<double> mass, bool integral);
  static std::uint64_t hash_of(std::span<const std::uint32_t> index, std::span<const double> mass);

  std::uint32_t nnz(std::uint32_t id) const { return std::uint32_t(offsets_[id + 1] - offsets_[id]); }
  std::span<const std::uint32_t> index(std::uint32_t id) const {
    return {index_.data() + offsets_[id], std::size_t(offsets_[id + 1] - offsets_[id])};
  }
  std::span<const double> mass(std::uint32_t id) const {
    return {mass_.data() + offsets_[id], std::size_t(offsets_[id + 1] - offsets_[id])};
  }
  double total(std::uint32_t id) const { return total_[id]; }
  /// @brief The l1-normalised mixture (weights mass/total).
  SparseMixture mixture(std::uint32_t id) const;

  std::uint64_t multiplicity(std::uint32_t id) const { return multiplicity_[id]; }
  int first_level(std::uint32_t id) const { return first_level_[id]; }
  std::uint64_t first_voxel(std::uint32_t id) const { return first_voxel_[id]; }
  std::uint64_t total_nnz() const { return index_.size(); }

  /// @brief Used by the mipmap builder once all levels are known.
  void set_multiplicities(std::vector<std::uint64_t> m) { multiplicity_ = std::move(m); }
  /// @brief Used by the mipmap builder once the table is complete: frees the hash index and the arrays'
  /// spare capacity (a large table is otherwise held at up to twice its size through the
  /// factorisation). intern() still works afterwards; it rebuilds the index first.
  void compact();

 private:
  void grow_hash();

  std::uint32_t num_sources_ = 0;
  bool integral_ = true;
  std::vector<std::uint64_t> offsets_{0};
  std::vector<std::uint32_t> index_;
  std::vector<double> mass_;
  std::vector<double> total_;
  std::vector<std::uint64_t> hash_;
  std::vector<std::uint64_t> multiplicity_;
  std::vector<std::uint8_t> first_level_;
  std::vector<std::uint64_t> first_voxel_;
  std::vector<std::uint32_t> slots_;  // open addressing over ids; ~0u = empty
};

}  // namespace strata::mixture
