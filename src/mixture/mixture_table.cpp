#include "strata/mixture/mixture_table.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <numeric>

#include "strata/core/error.hpp"
#include "strata/mixture/flat_hash.hpp"

namespace strata::mixture {

namespace {
constexpr std::uint32_t kEmpty = ~0u;
constexpr double kExactLimit = 9007199254740992.0;  // 2^53
}  // namespace

MixtureTable::MixtureTable(std::uint32_t num_sources, bool integral) : num_sources_(num_sources), integral_(integral) {
  if (num_sources == kEmpty) throw Error("mixture table: too many sources");
  offsets_.reserve(std::size_t(num_sources) + 1);
  for (std::uint32_t s = 0; s < num_sources; ++s) {
    const double one = 1.0;
    intern(std::span<const std::uint32_t>(&s, 1), std::span<const double>(&one, 1), 0, kNoVoxel);
  }
}

void MixtureTable::canonicalize(std::span<double> mass, bool integral) {
  if (mass.empty()) return;
  if (integral) {
    std::uint64_t g = 0;
    for (double m : mass) {
      if (!(m >= 1.0) || m > kExactLimit || m != std::floor(m))
        throw Error("mixture table: integral mass " + std::to_string(m) + " is not an integer in [1, 2^53]");
      g = std::gcd(g, std::uint64_t(m));
      if (g == 1) return;
    }
    for (double& m : mass) m = double(std::uint64_t(m) / g);
  } else {
    double t = 0.0;
    for (double m : mass) t += m;
    for (double& m : mass) m /= t;
  }
}

std::uint64_t MixtureTable::hash_of(std::span<const std::uint32_t> index, std::span<const double> mass) {
  std::uint64_t h = 0x51ed270b27a0c2d1ULL ^ index.size();
  for (std::size_t i = 0; i < index.size(); ++i) {
    h = splitmix64(h ^ index[i]);
    h = splitmix64(h ^ std::bit_cast<std::uint64_t>(mass[i]));
  }
  return h;
}

void MixtureTable::grow_hash() {
  if (hash_.size() != total_.size()) {  // after compact(): the hashes again
    hash_.resize(total_.size());
    for (std::uint32_t id = 0; id < size(); ++id) hash_[id] = hash_of(index(id), mass(id));
  }
  std::size_t cap = 64;
  while (cap < 2 * (std::size_t(size()) + 1)) cap <<= 1;
  cap = std::max(cap, slots_.size() * 2);
  slots_.assign(cap, kEmpty);
  const std::size_t mask = cap - 1;
  for (std::uint32_t id = 0; id < size(); ++id) {
    std::size_t i = hash_[id] & mask;
    while (slots_[i] != kEmpty) i = (i + 1) & mask;
    slots_[i] = id;
  }
}

std::uint32_t MixtureTable::intern(std::span<const std::uint32_t> index, std::span<const double> mass, std::uint64_t hash,
                                   int level, std::uint64_t voxel) {
  if (2 * (std::size_t(size()) + 1) > slots_.size() || hash_.size() != total_.size()) grow_hash();
  const std::size_t mask = slots_.size() - 1;
  std::size_t i = hash & mask;
  for (;; i = (i + 1) & mask) {
    const std::uint32_t id = slots_[i];
    if (id == kEmpty) break;
    if (hash_[id] != hash || nnz(id) != index.size()) continue;
    const auto* ix = index_.data() + offsets_[id];
    const auto* ms = mass_.data() + offsets_[id];
    if (std::memcmp(ix, index.data(), index.size() * sizeof(std::uint32_t)) == 0 &&
        std::memcmp(ms, mass.data(), mass.size() * sizeof(double)) == 0)
      return id;
  }
  const std::uint32_t id = size();
  if (id == kEmpty - 1) throw Error("mixture table: more than 2^32 - 2 distinct mixtures");
  slots_[i] = id;
  index_.insert(index_.end(), index.begin(), index.end());
  mass_.insert(mass_.end(), mass.begin(), mass.end());
  offsets_.push_back(index_.size());
  double t = 0.0;
  for (double m : mass) t += m;
  total_.push_back(t);
  hash_.push_back(hash);
  multiplicity_.push_back(0);
  first_level_.push_back(std::uint8_t(level));
  first_voxel_.push_back(voxel);
  return id;
}

SparseMixture MixtureTable::mixture(std::uint32_t id) const {
  const auto ix = index(id);
  const auto ms = mass(id);
  std::vector<SparseEntry> e(ix.size());
  const double t = total_[id];
  for (std::size_t i = 0; i < ix.size(); ++i) e[i] = {ix[i], ms[i] / t};
  return SparseMixture::from_sorted(std::move(e));
}

void MixtureTable::compact() {
  slots_ = {};
  hash_ = {};
  offsets_.shrink_to_fit();
  index_.shrink_to_fit();
  mass_.shrink_to_fit();
  total_.shrink_to_fit();
  multiplicity_.shrink_to_fit();
  first_level_.shrink_to_fit();
  first_voxel_.shrink_to_fit();
}

}  // namespace strata::mixture
