#include "strata/mixture/lookup.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::mixture {

namespace {

inline double sq(double x) { return x * x; }

inline double combine_sigma(double mu, double a, double da, double b, double db, double w, double dw, ErrorModel model) {
  if (model == ErrorModel::linear)
    return std::sqrt(sq(1.0 - w) * sq(da) + sq(w) * sq(db) + sq(b - a) * sq(dw));
  const double ra = a != 0.0 ? da / a : 0.0;
  const double rb = b != 0.0 ? db / b : 0.0;
  const double rw = w != 0.0 ? dw / w : 0.0;
  return std::sqrt(sq(mu) * (sq(ra) + sq(rb) + 2.0 * sq(rw)));
}

// Merges two sparse vectors; emit(index, mean, sigma) in index order. Returns the count.
template <class Emit>
std::size_t merge_lerp(const std::uint32_t* ia, const double* a, const double* da, std::size_t na, const std::uint32_t* ib,
                       const double* b, const double* db, std::size_t nb, double w, double dw, ErrorModel model, Emit&& emit) {
  std::size_t i = 0, j = 0, n = 0;
  while (i < na || j < nb) {
    std::uint32_t k;
    double av = 0, dav = 0, bv = 0, dbv = 0;
    if (j == nb || (i < na && ia[i] < ib[j])) {
      k = ia[i], av = a[i], dav = da[i], ++i;
    } else if (i == na || ib[j] < ia[i]) {
      k = ib[j], bv = b[j], dbv = db[j], ++j;
    } else {
      k = ia[i], av = a[i], dav = da[i], bv = b[j], dbv = db[j], ++i, ++j;
    }
    const double mu = (1.0 - w) * av + w * bv;
    emit(n++, k, mu, combine_sigma(mu, av, dav, bv, dbv, w, dw, model));
  }
  return n;
}

std::size_t union_size(const std::uint32_t* ia, std::size_t na, const std::uint32_t* ib, std::size_t nb) {
  std::size_t i = 0, j = 0, n = 0;
  while (i < na && j < nb) {
    if (ia[i] < ib[j]) ++i;
    else if (ib[j] < ia[i]) ++j;
    else ++i, ++j;
    ++n;
  }
  return n + (na - i) + (nb - j);
}

}  // namespace

MixtureLookup MixtureLookup::build(const MixtureGraph& g, const Schedule& schedule, ErrorModel model) {
  if (schedule.order.size() != g.nodes.size()) throw Error("mixture lookup: schedule does not match the graph");
  MixtureLookup L;
  const std::uint64_t nodes = g.node_count();
  L.offset_.assign(nodes, 0);
  L.length_.assign(nodes, 0);
  const std::uint32_t N = g.num_sources;
  L.index_.resize(N);
  L.mean_.assign(N, 1.0);
  L.sigma_.assign(N, 0.0);
  for (std::uint32_t s = 0; s < N; ++s) {
    L.offset_[s] = s;
    L.length_[s] = 1;
    L.index_[s] = s;
  }
  const int nt = thread_count();
  for (std::uint32_t p = 1; p <= schedule.depth; ++p) {
    const auto phase = schedule.phase(p);
    const std::int64_t n = std::int64_t(phase.size());
#pragma omp parallel for num_threads(nt) schedule(dynamic, 256) if (n > 1024)
    for (std::int64_t i = 0; i < n; ++i) {
      const std::uint32_t id = phase[std::size_t(i)];
      const InternalNode& nd = g.node(id);
      L.length_[id] = std::uint32_t(union_size(L.index_.data() + L.offset_[nd.a], L.length_[nd.a],
                                                L.index_.data() + L.offset_[nd.b], L.length_[nd.b]));
    }
    std::uint64_t end = L.index_.size();
    for (std::uint32_t id : phase) {
      L.offset_[id] = end;
      end += L.length_[id];
    }
    L.index_.resize(end);
    L.mean_.resize(end);
    L.sigma_.resize(end);
#pragma omp parallel for num_threads(nt) schedule(dynamic, 256) if (n > 1024)
    for (std::int64_t i = 0; i < n; ++i) {
      const std::uint32_t id = phase[std::size_t(i)];
      const InternalNode& nd = g.node(id);
      const std::uint64_t oa = L.offset_[nd.a], ob = L.offset_[nd.b], o = L.offset_[id];
      merge_lerp(L.index_.data() + oa, L.mean_.data() + oa, L.sigma_.data() + oa, L.length_[nd.a], L.index_.data() + ob,
                 L.mean_.data() + ob, L.sigma_.data() + ob, L.length_[nd.b], g.codebook.value[nd.bin],
                 g.codebook.sigma[nd.bin], model, [&](std::size_t k, std::uint32_t idx, double mu, double s) {
                   L.index_[o + k] = idx;
                   L.mean_[o + k] = mu;
                   L.sigma_[o + k] = s;
                 });
    }
  }
  return L;
}

SparseMixture reconstruct(const Factorization& f, const MixtureLookup& lookup, int level, std::int64_t x, std::int64_t y,
                          std::int64_t z) {
  if (level < 0 || std::size_t(level) >= f.levels.size()) throw Error("mixture reconstruct: level " + std::to_string(level) + " out of range");
  const MipLevel& L = f.levels[std::size_t(level)];
  if (x < 0 || y < 0 || z < 0 || x >= L.dims.x || y >= L.dims.y || z >= L.dims.z)
    throw Error("mixture reconstruct: voxel outside level " + std::to_string(level) + " of size " + L.dims.to_string());
  return lookup.mean(L.ids[L.index(x, y, z)]);
}

ErrorReport measure_error(const HistogramMipmap& h, const Factorization& f, const MixtureLookup& lookup) {
  const MixtureTable& t = h.table();
  const std::int64_t n = t.size();
  std::vector<double> err(std::size_t(n), 0.0);
#pragma omp parallel for num_threads(thread_count()) schedule(dynamic, 64)
  for (std::int64_t id = 0; id < n; ++id) {
    const std::uint32_t node = f.node_of_mixture[std::size_t(id)];
    const auto ix = t.index(std::uint32_t(id));
    const auto ms = t.mass(std::uint32_t(id));
    const double total = t.total(std::uint32_t(id));
    const auto jx = lookup.index(node);
    const auto mu = lookup.mean_weights(node);
    double d = 0.0;
    std::size_t i = 0, j = 0;
    while (i < ix.size() || j < jx.size()) {
      if (j == jx.size() || (i < ix.size() && ix[i] < jx[j])) d += ms[i++] / total;
      else if (i == ix.size() || jx[j] < ix[i]) d += std::abs(mu[j++]);
      else d += std::abs(ms[i++] / total - mu[j++]);
    }
    err[std::size_t(id)] = d;
  }
  ErrorReport r;
  double sum = 0.0;
  std::uint64_t voxels = 0;
  for (std::uint32_t id = 0; id < t.size(); ++id) {
    const std::uint64_t m = t.multiplicity(id);
    if (m == 0) continue;
    if (err[id] > r.max_l1) r.max_l1 = err[id], r.worst_mixture = id;
    sum += double(m) * err[id];
    voxels += m;
  }
  r.mean_l1 = voxels ? sum / double(voxels) : 0.0;
  for (const MipLevel& L : h.levels()) {
    double m = 0.0;
    for (std::uint32_t id : L.ids) m = std::max(m, err[id]);
    r.level_max_l1.push_back(m);
  }
  return r;
}

}  // namespace strata::mixture
