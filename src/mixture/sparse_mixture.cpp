#include "strata/mixture/sparse_mixture.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "strata/core/error.hpp"

namespace strata::mixture {

SparseMixture SparseMixture::from_entries(std::vector<SparseEntry> entries) {
  for (const auto& e : entries)
    if (!(e.weight >= 0.0) || !std::isfinite(e.weight))
      throw Error("mixture: weight of index " + std::to_string(e.index) + " must be finite and >= 0, got " +
                  std::to_string(e.weight));
  std::sort(entries.begin(), entries.end(), [](const SparseEntry& a, const SparseEntry& b) { return a.index < b.index; });
  std::size_t out = 0;
  for (std::size_t i = 0; i < entries.size();) {
    SparseEntry e = entries[i++];
    while (i < entries.size() && entries[i].index == e.index) e.weight += entries[i++].weight;
    if (e.weight > 0.0) entries[out++] = e;
  }
  entries.resize(out);
  SparseMixture m;
  m.entries_ = std::move(entries);
  return m;
}

SparseMixture SparseMixture::from_sorted(std::vector<SparseEntry> entries) {
#ifndef NDEBUG
  for (std::size_t i = 0; i < entries.size(); ++i) {
    assert(entries[i].weight > 0.0);
    assert(i == 0 || entries[i - 1].index < entries[i].index);
  }
#endif
  SparseMixture m;
  m.entries_ = std::move(entries);
  return m;
}

SparseMixture SparseMixture::from_sorted(std::span<const std::uint32_t> index, std::span<const double> weight) {
  std::vector<SparseEntry> e(index.size());
  for (std::size_t i = 0; i < index.size(); ++i) e[i] = {index[i], weight[i]};
  return from_sorted(std::move(e));
}

double SparseMixture::weight(std::uint32_t index) const {
  auto it = std::lower_bound(entries_.begin(), entries_.end(), index,
                             [](const SparseEntry& e, std::uint32_t i) { return e.index < i; });
  return (it != entries_.end() && it->index == index) ? it->weight : 0.0;
}

bool SparseMixture::contains(std::uint32_t index) const { return weight(index) != 0.0; }

double SparseMixture::total() const {
  double t = 0.0;
  for (const auto& e : entries_) t += e.weight;
  return t;
}

void SparseMixture::normalize() {
  const double t = total();
  if (t <= 0.0) return;
  for (auto& e : entries_) e.weight /= t;
}

void SparseMixture::add_scaled(const SparseMixture& o, double s) {
  std::vector<SparseEntry> out;
  out.reserve(entries_.size() + o.entries_.size());
  std::size_t i = 0, j = 0;
  while (i < entries_.size() || j < o.entries_.size()) {
    if (j == o.entries_.size() || (i < entries_.size() && entries_[i].index < o.entries_[j].index)) {
      out.push_back(entries_[i++]);
    } else if (i == entries_.size() || o.entries_[j].index < entries_[i].index) {
      const double w = s * o.entries_[j].weight;
      if (w != 0.0) out.push_back({o.entries_[j].index, w});
      ++j;
    } else {
      const double w = entries_[i].weight + s * o.entries_[j].weight;
      if (w != 0.0) out.push_back({entries_[i].index, w});
      ++i, ++j;
    }
  }
  entries_ = std::move(out);
}

SparseMixture SparseMixture::lerp(const SparseMixture& a, const SparseMixture& b, double w) {
  SparseMixture m;
  m.entries_.reserve(a.nnz() + b.nnz());
  for (const auto& e : a.entries_)
    if ((1.0 - w) * e.weight != 0.0) m.entries_.push_back({e.index, (1.0 - w) * e.weight});
  m.add_scaled(b, w);
  return m;
}

double SparseMixture::l1_distance(const SparseMixture& a, const SparseMixture& b) {
  double d = 0.0;
  std::size_t i = 0, j = 0;
  const auto& x = a.entries_;
  const auto& y = b.entries_;
  while (i < x.size() || j < y.size()) {
    if (j == y.size() || (i < x.size() && x[i].index < y[j].index)) {
      d += std::abs(x[i++].weight);
    } else if (i == x.size() || y[j].index < x[i].index) {
      d += std::abs(y[j++].weight);
    } else {
      d += std::abs(x[i++].weight - y[j++].weight);
    }
  }
  return d;
}

double SparseMixture::dot(std::span<const double> x) const {
  double s = 0.0;
  for (const auto& e : entries_) s += e.weight * x[e.index];
  return s;
}

}  // namespace strata::mixture
