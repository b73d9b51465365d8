#include "strata/mixture/box_query.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <tuple>

#include <omp.h>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/mixture/flat_hash.hpp"

namespace strata::mixture {

namespace {

constexpr std::uint32_t kNoNode = std::numeric_limits<std::uint32_t>::max();

struct NodeAcc {
  double w = 0.0;   // sum of sample weights (voxels covered)
  double w2 = 0.0;  // sum of squared sample weights (variance scale)
};
using NodeMap = detail::FlatMap<std::uint32_t, NodeAcc>;

// Dense per-source accumulator with a touched list, reused across queries on one thread so a
// small query does not pay for zeroing num_sources entries.
struct SourceSink {
  std::vector<double> count, var;
  std::vector<double> spread;  // coarse: summed placement standard deviations (correlated)
  std::vector<std::uint8_t> mark;
  std::vector<std::uint32_t> touched;
  std::vector<std::pair<std::uint32_t, NodeAcc>> pending;  // expand()'s internal nodes

  void prepare(std::uint32_t ns) {
    if (count.size() < ns) {
      count.resize(ns, 0.0);
      var.resize(ns, 0.0);
      spread.resize(ns, 0.0);
      mark.resize(ns, 0);
    }
  }
  void touch(std::uint32_t s) {
    if (!mark[s]) {
      mark[s] = 1;
      touched.push_back(s);
    }
  }
  void add(std::uint32_t s, double c) {
    touch(s);
    count[s] += c;
  }
  // A drained entry back in (merging histograms): counts add, variances add.
  void add(const BoxCount& c) {
    add(c.source, c.count);
    var[c.source] += c.sigma * c.sigma;
  }
  // Every node of `nodes` through the lookup: returns how many internal nodes were expanded.
  // The nodes are listed first so their lookup entries can be prefetched ahead of use: on large
  // volumes the expansion is bound by the latency of those scattered reads, not by arithmetic.
  std::uint64_t expand(const NodeMap& nodes, const MixtureLookup& lookup, std::uint32_t ns) {
    pending.clear();
    nodes.for_each([&](std::uint32_t id, const NodeAcc& a) {
      if (id < ns) {
        add(id, a.w);
      } else {
        pending.push_back({id, a});
      }
    });
    constexpr std::size_t kNodeAhead = 16, kEntriesAhead = 8;
    const std::size_t n = pending.size();
    for (std::size_t i = 0; i < std::min(n, kNodeAhead); ++i) lookup.prefetch_node(pending[i].first);
    for (std::size_t i = 0; i < std::min(n, kEntriesAhead); ++i) lookup.prefetch_entries(pending[i].first);
    for (std::size_t i = 0; i < n; ++i) {
      if (i + kNodeAhead < n) lookup.prefetch_node(pending[i + kNodeAhead].first);
      if (i + kEntriesAhead < n) lookup.prefetch_entries(pending[i + kEntriesAhead].first);
      const std::uint32_t id = pending[i].first;
      const auto ix = lookup.index(id);
      const auto mu = lookup.mean_weights(id);
      const auto sg = lookup.sigma(id);
      // The lookup's means are convex combinations of unit vectors: they sum to 1 to rounding,
      // so the counts of all nodes sum to the box volume without renormalising.
      const double w = pending[i].second.w, w2 = pending[i].second.w2;
      for (std::size_t k = 0; k < ix.size(); ++k) {
        const std::uint32_t s = ix[k];
        touch(s);
        count[s] += w * mu[k];
        var[s] += w2 * sg[k] * sg[k];
      }
    }
    return n;
  }
  // A partly covered cell of the coarse method: `n` of its `total` voxels lie in the box. Label
  // s has about c = total mu_s voxels in the cell, so the box holds between lo = max(0, n -
  // (total - c)) and hi = min(n, c) of them wherever they sit, while the estimate is n mu_s. Its
  // error is taken as uniform over [lo, hi] around that estimate: the root of range^2 / 12 plus
  // the squared offset of the range's middle from the estimate (n mu_s can lie near one end).
  // Labels are spatially coherent, so a label cut by one face is cut the same way in the
  // neighbouring cells: the placement errors of one label add up as fully correlated (standard
  // deviations summed, then squared into the variance at drain), not as independent cells.
  // `bias_lo`, `bias_hi` (1 for an ordinary cell): for a cell cut by the far border, the range
  // of total x voxel weight (border_weight_range), so the cell holds between c / bias_hi and
  // c / bias_lo voxels of label s instead of exactly c.
  void add_placement(std::uint32_t node, double n, double total, double bias_lo, double bias_hi,
                     const MixtureLookup& lookup, std::uint32_t ns) {
    if (node < ns) return;  // one label fills the cell: no uncertainty however it is cut
    const auto ix = lookup.index(node);
    const auto mu = lookup.mean_weights(node);
    for (std::size_t k = 0; k < ix.size(); ++k) {
      const double c = total * mu[k];
      const double c_lo = c / bias_hi, c_hi = std::min(total, c / bias_lo);
      const double lo = std::max(0.0, n - (total - c_lo)), hi = std::min(n, c_hi);
      const double range = hi - lo, off = 0.5 * (lo + hi) - n * mu[k];
      touch(ix[k]);
      spread[ix[k]] += std::sqrt(range * range / 12.0 + off * off);
    }
  }
  // Zeroes the touched entries (after an exception; drain() leaves nothing behind).
  void clear() {
    for (std::uint32_t s : touched) count[s] = var[s] = spread[s] = 0.0, mark[s] = 0;
    touched.clear();
  }
  // Moves the touched entries out (ascending source) and clears them.
  void drain(std::vector<BoxCount>& out) {
    // Already sorted when one node dominated (the lookup's indices ascend), e.g. whole volumes.
    if (!std::is_sorted(touched.begin(), touched.end())) std::sort(touched.begin(), touched.end());
    out.reserve(out.size() + touched.size());
    for (std::uint32_t s : touched) {
      if (count[s] > 0.0) out.push_back({s, count[s], std::sqrt(var[s] + spread[s] * spread[s])});
      count[s] = 0.0;
      var[s] = 0.0;
      spread[s] = 0.0;
      mark[s] = 0;
    }
    touched.clear();
  }
};

SourceSink& local_sink(std::uint32_t ns) {
  thread_local SourceSink sink;
  sink.prepare(ns);
  return sink;
}

// Leaves the thread's sink clean however the query ends.
struct SinkGuard {
  SourceSink& sink;
  ~SinkGuard() { sink.clear(); }
};

std::vector<std::uint32_t>& local_buffer(std::size_t n) {
  thread_local std::vector<std::uint32_t> buf;
  if (buf.size() < n) buf.resize(n);
  return buf;
}

// Level-0 ids with weight 1 each: run-length, sources straight to the sink.
inline void accumulate_unit(const std::uint32_t* ids, std::size_t n, std::uint32_t ns, SourceSink& sink,
                            NodeMap& nodes) {
  std::size_t i = 0;
  while (i < n) {
    const std::uint32_t id = ids[i];
    std::size_t j = i + 1;
    while (j < n && ids[j] == id) ++j;
    const double r = double(j - i);
    if (id < ns) {
      sink.add(id, r);
    } else {
      NodeAcc* a = nodes.insert(id, {}).first;
      a->w += r;
      a->w2 += r;
    }
    i = j;
  }
}

struct Piece {
  std::int64_t start = 0;
  int k = 0;              // log2 nominal size
  std::int64_t length = 0;  // real length (clipped at the volume border)
};

std::vector<Piece> pieces_of(std::int64_t lo, std::int64_t hi, std::int64_t dim, int max_level) {
  std::vector<Piece> out;
  for (const auto& [p, k] : aligned_pieces(lo, hi, dim, max_level))
    out.push_back({p, k, std::min<std::int64_t>(std::int64_t(1) << k, dim - p)});
  return out;
}

std::int64_t cells(std::int64_t length, int l) { return (length + (std::int64_t(1) << l) - 1) >> l; }

// The level-l cells meeting `box` (level-l coordinates): [lo >> l, ((hi - 1) >> l) + 1) per axis.
Box cell_box(const Box& box, int l) {
  return {{box.lo.x >> l, box.lo.y >> l, box.lo.z >> l},
          {((box.hi.x - 1) >> l) + 1, ((box.hi.y - 1) >> l) + 1, ((box.hi.z - 1) >> l) + 1}};
}

// Per-axis overlap of each level-l cell c in [c0, c1) with [lo, hi): w[c - c0] = voxels of
// [c 2^l, (c + 1) 2^l) inside [lo, hi). With [0, dim) it is the cell's support in the volume.
void cell_overlaps(std::vector<double>& w, std::int64_t c0, std::int64_t c1, std::int64_t lo, std::int64_t hi, int l) {
  w.resize(std::size_t(c1 - c0));
  for (std::int64_t c = c0; c < c1; ++c) {
    const std::int64_t a = std::max(lo, c << l), e = std::min(hi, (c + 1) << l);
    w[std::size_t(c - c0)] = double(e - a);
  }
}

// Eq. 4 averages a voxel's children with equal weights, so in a level-l cell cut by the
// volume's far border (real length e < 2^l along an axis) the level-0 voxels carry unequal
// weights when some split on the way down has halves of unequal length (e = 3: 1/2 for the
// first two voxels together, 1/2 for the third). The cell's mixture is then not its support's
// histogram. Returns, along one axis, the smallest and largest voxel weight times e (both 1 for
// an unbiased cell: full, or e a power of two).
std::pair<double, double> border_weight_range(std::int64_t e, int l) {
  // Walks down the cut right-most node: at each level where it has two children, the left one
  // is full (its voxels weigh 2^-(j-1) of it) and the right one carries on with half the weight.
  double factor = 1.0;  // weight of the current cut node within the cell
  double wmin = std::numeric_limits<double>::infinity(), wmax = 0.0;
  std::int64_t length = e;
  for (int j = l; j > 0; --j) {
    const std::int64_t half = std::int64_t(1) << (j - 1);
    if (length <= half) continue;  // one child: weight passes through
    // A full left half (voxel weight 2^-(j-1) within it) and the cut right rest.
    const double left = factor * 0.5 * std::ldexp(1.0, -(j - 1));
    wmin = std::min(wmin, left);
    wmax = std::max(wmax, left);
    factor *= 0.5;
    length -= half;
  }
  wmin = std::min(wmin, factor);  // the last node holds one voxel
  wmax = std::max(wmax, factor);
  return {wmin * double(e), wmax * double(e)};
}

}  // namespace

std::string_view query_method_name(QueryMethod m) {
  switch (m) {
    case QueryMethod::hybrid: return "hybrid";
    case QueryMethod::footprint: return "footprint";
    case QueryMethod::naive: return "naive";
    case QueryMethod::coarse: return "coarse";
  }
  return "?";
}

QueryMethod parse_query_method(std::string_view name) {
  if (name == "hybrid") return QueryMethod::hybrid;
  if (name == "footprint") return QueryMethod::footprint;
  if (name == "naive") return QueryMethod::naive;
  if (name == "coarse") return QueryMethod::coarse;
  throw Error("query method: expected hybrid, footprint, naive or coarse, got '" + std::string(name) + "'");
}

double BoxHistogram::total() const {
  double t = 0.0;
  for (const auto& c : counts) t += c.count;
  return t;
}

const BoxCount* BoxHistogram::find(std::uint32_t source) const {
  auto it = std::lower_bound(counts.begin(), counts.end(), source,
                             [](const BoxCount& c, std::uint32_t s) { return c.source < s; });
  return it != counts.end() && it->source == source ? &*it : nullptr;
}

// Greedy from lo: the largest aligned piece that fits. A piece of level k at p (p a multiple of
// 2^k) may run past dim when hi == dim and the real length dim - p is a power of two: the
// level-k voxel then has a single chain of children down to a full voxel of that size, so its
// mixture is the exact histogram of its real support. (Eq. 4 averages children with equal
// weights: a border voxel whose children have unequal supports - real length not a power of
// two - is NOT the histogram of its support, so it is never sampled.)
std::vector<std::pair<std::int64_t, int>> aligned_pieces(std::int64_t lo, std::int64_t hi, std::int64_t dim,
                                                          int max_level) {
  std::vector<std::pair<std::int64_t, int>> out;
  if (lo < 0 || hi > dim || lo >= hi) throw Error("aligned_pieces: range [" + std::to_string(lo) + ", " +
                                                  std::to_string(hi) + ") not inside [0, " + std::to_string(dim) + ")");
  const bool to_end = hi == dim;
  std::int64_t p = lo;
  while (p < hi) {
    int k = 0;
    while (k + 1 <= max_level) {
      const std::int64_t size = std::int64_t(1) << (k + 1);
      if (p % size != 0) break;
      if (p + size <= hi) {
        ++k;
        continue;
      }
      // Past the end: only for a range ending at the border whose rest is a power of two.
      if (to_end && std::has_single_bit(std::uint64_t(dim - p))) {
        ++k;
        continue;
      }
      break;
    }
    out.emplace_back(p, k);
    p = std::min(hi, p + (std::int64_t(1) << k));
  }
  return out;
}

BoxQuery::BoxQuery(const NodeGrid& grid, const MixtureLookup& lookup, std::uint32_t num_sources)
    : grid_(grid), lookup_(lookup), num_sources_(num_sources) {
  if (grid.level_count() <= 0) throw Error("box query: the node grid has no levels");
  for (int l = 0; l < grid.level_count(); ++l) dims_.push_back(grid.level_dims(l));
  const auto expect = mip_level_dims(dims_[0]);
  if (expect.size() != dims_.size()) throw Error("box query: the node grid's levels are not a full mip chain");
  for (std::size_t l = 0; l < dims_.size(); ++l)
    if (!(expect[l] == dims_[l])) throw Error("box query: level " + std::to_string(l) + " has dims " +
                                              dims_[l].to_string() + ", expected " + expect[l].to_string());
}

void BoxQuery::check(const Box& box) const {
  if (box.empty() || !Box::whole(dims_[0]).contains(box))
    throw Error("box query: box " + box.to_string() + " is empty or not inside the volume (" + dims_[0].to_string() +
                ")");
}

std::vector<FootprintBox> BoxQuery::plan(const Box& box, const QueryOptions& options) const {
  check(box);
  const int lmax = int(dims_.size()) - 1;
  const auto px = pieces_of(box.lo.x, box.hi.x, dims_[0].x, lmax);
  const auto py = pieces_of(box.lo.y, box.hi.y, dims_[0].y, lmax);
  const auto pz = pieces_of(box.lo.z, box.hi.z, dims_[0].z, lmax);
  std::vector<FootprintBox> out;
  out.reserve(px.size() * py.size() * pz.size());
  const bool hybrid = options.method == QueryMethod::hybrid;
  // A short row costs a cache line of its own; long rows stream (about one voxel's cost).
  auto row_cost = [&](std::int64_t length) { return length <= 16 ? options.row_cost : 1.0; };
  double plan_cost = 0.0;
  // Scanning the whole box at level 0 in one go (small boxes): the plan must beat this.
  const Extent bs = box.size();
  const double scan_cost =
      double(box.voxel_count()) + double(bs.y) * double(bs.z) * row_cost(bs.x) + options.box_cost;
  for (const Piece& z : pz)
    for (const Piece& y : py)
      for (const Piece& x : px) {
        const int m = std::min({x.k, y.k, z.k});
        int level = m;
        if (hybrid) {
          double best = std::numeric_limits<double>::infinity();
          for (int l = 0; l <= m; ++l) {
            const double rows = double(cells(y.length, l)) * double(cells(z.length, l));
            const double n = double(cells(x.length, l)) * rows;
            const double cost = n * (l == 0 ? 1.0 : options.sample_cost) + rows * row_cost(cells(x.length, l)) +
                                options.box_cost;
            if (cost < best) best = cost, level = l;
          }
          plan_cost += best;
          if (plan_cost >= scan_cost) return {FootprintBox{0, box, box}};
        }
        FootprintBox b;
        b.level = level;
        b.covered = {{x.start, y.start, z.start}, {x.start + x.length, y.start + y.length, z.start + z.length}};
        b.cells = {{x.start >> level, y.start >> level, z.start >> level},
                   {(x.start >> level) + cells(x.length, level), (y.start >> level) + cells(y.length, level),
                    (z.start >> level) + cells(z.length, level)}};
        // Adjacent level-0 boxes along x (the thin pieces at either end of the x range) read
        // their rows as one segment: one cache line per row instead of one per piece.
        if (level == 0 && !out.empty()) {
          FootprintBox& prev = out.back();
          if (prev.level == 0 && prev.covered.hi.x == b.covered.lo.x && prev.covered.lo.y == b.covered.lo.y &&
              prev.covered.hi.y == b.covered.hi.y && prev.covered.lo.z == b.covered.lo.z &&
              prev.covered.hi.z == b.covered.hi.z) {
            prev.covered.hi.x = prev.cells.hi.x = b.covered.hi.x;
            continue;
          }
        }
        out.push_back(b);
      }
  return out;
}

BoxHistogram BoxQuery::run(const Box& box, const QueryOptions& options) const {
  if (options.method == QueryMethod::naive) return naive(box, options.threads);
  if (options.method == QueryMethod::coarse) return coarse(box, options.max_samples);
  const auto plan_boxes = plan(box, options);
  BoxHistogram result;
  result.box = box;
  result.pieces = plan_boxes.size();

  std::uint64_t samples_estimate = 0;
  for (const auto& b : plan_boxes)
    if (b.level > 0) samples_estimate += std::uint64_t(b.cells.voxel_count());
  // Distinct nodes are far fewer than samples (coherent labels); the map grows when needed.
  NodeMap nodes(kNoNode, std::min<std::uint64_t>(samples_estimate / 4 + 16, 4096));
  SourceSink& sink = local_sink(num_sources_);
  const SinkGuard guard{sink};
  const std::uint32_t ns = num_sources_;

  std::vector<double> wx, wy, wz;
  for (const FootprintBox& b : plan_boxes) {
    const std::uint64_t n = std::uint64_t(b.cells.voxel_count());
    auto& buf = local_buffer(n);
    const Extent cs = b.cells.size();
    if (cs.x <= 4) {
      // Short rows (the x faces of the shell): per-voxel reads beat a copy call per row.
      std::uint32_t* o = buf.data();
      for (std::int64_t z = b.cells.lo.z; z < b.cells.hi.z; ++z)
        for (std::int64_t y = b.cells.lo.y; y < b.cells.hi.y; ++y)
          for (std::int64_t x = b.cells.lo.x; x < b.cells.hi.x; ++x) *o++ = grid_.node_at(b.level, x, y, z);
    } else {
      grid_.decode_box(b.level, b.cells, {buf.data(), n});
    }
    result.fetches += n;
    if (b.level == 0) {
      result.level0_voxels += n;
      accumulate_unit(buf.data(), n, ns, sink, nodes);
      continue;
    }
    result.samples += n;
    // Per-axis support of each cell (only the last one can be clipped at the volume border).
    cell_overlaps(wx, b.cells.lo.x, b.cells.hi.x, b.covered.lo.x, b.covered.hi.x, b.level);
    cell_overlaps(wy, b.cells.lo.y, b.cells.hi.y, b.covered.lo.y, b.covered.hi.y, b.level);
    cell_overlaps(wz, b.cells.lo.z, b.cells.hi.z, b.covered.lo.z, b.covered.hi.z, b.level);
    const std::size_t sx = wx.size(), sy = wy.size(), sz = wz.size();
    const std::uint32_t* id = buf.data();
    for (std::size_t z = 0; z < sz; ++z)
      for (std::size_t y = 0; y < sy; ++y) {
        const double wyz = wy[y] * wz[z];
        std::size_t x = 0;
        while (x < sx) {
          const std::uint32_t node = id[x];
          double w = wx[x] * wyz, w2 = w * w;
          std::size_t j = x + 1;
          for (; j < sx && id[j] == node; ++j) {
            const double v = wx[j] * wyz;
            w += v;
            w2 += v * v;
          }
          if (node < ns) {
            sink.add(node, w);
          } else {
            NodeAcc* a = nodes.insert(node, {}).first;
            a->w += w;
            a->w2 += w2;
          }
          x = j;
        }
        id += sx;
      }
  }
  result.distinct_nodes = sink.expand(nodes, lookup_, ns);
  sink.drain(result.counts);
  return result;
}

int BoxQuery::coarse_level(const Box& box, std::uint64_t max_samples) const {
  check(box);
  if (max_samples == 0) throw Error("box query: max_samples must be at least 1");
  const int lmax = int(dims_.size()) - 1;
  for (int l = 0; l < lmax; ++l) {
    const Extent span = cell_box(box, l).size();
    const double n = double(span.x) * double(span.y) * double(span.z);
    if (n <= double(max_samples)) return l;
  }
  return lmax;
}

BoxHistogram BoxQuery::coarse(const Box& box, std::uint64_t max_samples) const {
  const int level = coarse_level(box, max_samples);
  if (level == 0) return naive(box, 1);  // every voxel fits the budget: exact
  const Box cells = cell_box(box, level);
  // Per axis and cell: voxels shared with the box (n) and the cell's support in the volume (N,
  // the overlap with [0, dim)). The box lies inside the volume, so clipping a cell at dim first
  // does not change its overlap with the box.
  struct Overlap {
    std::vector<double> n, support;
    std::vector<double> bias_lo, bias_hi;  // border_weight_range per cell (1, 1 when unbiased)
  };
  auto axis = [&](std::int64_t c0, std::int64_t c1, std::int64_t lo, std::int64_t hi, std::int64_t dim) {
    Overlap o;
    cell_overlaps(o.n, c0, c1, lo, hi, level);
    cell_overlaps(o.support, c0, c1, 0, dim, level);
    o.bias_lo.assign(o.support.size(), 1.0);
    o.bias_hi.assign(o.support.size(), 1.0);
    const std::size_t last = o.support.size() - 1;  // only the last cell can be cut by the border
    if (o.support[last] < std::ldexp(1.0, level))
      std::tie(o.bias_lo[last], o.bias_hi[last]) = border_weight_range(std::int64_t(o.support[last]), level);
    return o;
  };
  const Extent d0 = dims_[0];
  const Overlap ox = axis(cells.lo.x, cells.hi.x, box.lo.x, box.hi.x, d0.x);
  const Overlap oy = axis(cells.lo.y, cells.hi.y, box.lo.y, box.hi.y, d0.y);
  const Overlap oz = axis(cells.lo.z, cells.hi.z, box.lo.z, box.hi.z, d0.z);

  const std::uint64_t count = std::uint64_t(cells.voxel_count());
  auto& ids = local_buffer(count);
  grid_.decode_box(level, cells, {ids.data(), count});
  BoxHistogram result;
  result.box = box;
  result.pieces = 1;
  result.fetches = result.samples = count;
  NodeMap nodes(kNoNode, std::min<std::uint64_t>(count / 4 + 16, 4096));
  SourceSink& sink = local_sink(num_sources_);
  const SinkGuard guard{sink};
  struct Partial {
    std::uint32_t node;
    double n, total, bias_lo, bias_hi;
  };
  std::vector<Partial> partial;  // cells on the box's faces and biased border cells only
  const std::uint32_t* id = ids.data();
  for (std::size_t z = 0; z < oz.n.size(); ++z)
    for (std::size_t y = 0; y < oy.n.size(); ++y)
      for (std::size_t x = 0; x < ox.n.size(); ++x, ++id) {
        const double n = ox.n[x] * oy.n[y] * oz.n[z], total = ox.support[x] * oy.support[y] * oz.support[z];
        NodeAcc* a = nodes.insert(*id, {}).first;
        a->w += n;
        a->w2 += n * n;
        const double bias_lo = ox.bias_lo[x] * oy.bias_lo[y] * oz.bias_lo[z];
        const double bias_hi = ox.bias_hi[x] * oy.bias_hi[y] * oz.bias_hi[z];
        if (n < total || bias_lo != 1.0 || bias_hi != 1.0) partial.push_back({*id, n, total, bias_lo, bias_hi});
      }
  result.distinct_nodes = sink.expand(nodes, lookup_, num_sources_);
  for (const Partial& p : partial) sink.add_placement(p.node, p.n, p.total, p.bias_lo, p.bias_hi, lookup_, num_sources_);
  sink.drain(result.counts);
  return result;
}

BoxHistogram BoxQuery::naive(const Box& box, int threads) const {
  check(box);
  BoxHistogram result;
  result.box = box;
  result.pieces = 1;
  const Extent s = box.size();
  const std::uint64_t slice = std::uint64_t(s.x) * std::uint64_t(s.y);
  result.fetches = result.level0_voxels = std::uint64_t(box.voxel_count());
  const std::uint32_t ns = num_sources_;
  int nt = threads > 0 ? threads : thread_count();
  if (box.voxel_count() < 32768 || s.z < 2) nt = 1;
  nt = int(std::min<std::int64_t>(nt, s.z));

  if (nt == 1) {
    SourceSink& sink = local_sink(ns);
    const SinkGuard guard{sink};
    NodeMap nodes(kNoNode);
    auto& buf = local_buffer(slice);
    for (std::int64_t z = box.lo.z; z < box.hi.z; ++z) {
      grid_.decode_box(0, {{box.lo.x, box.lo.y, z}, {box.hi.x, box.hi.y, z + 1}}, {buf.data(), slice});
      accumulate_unit(buf.data(), slice, ns, sink, nodes);
    }
    result.distinct_nodes = sink.expand(nodes, lookup_, ns);
    sink.drain(result.counts);
    return result;
  }

  // Parallel over z: every thread accumulates into its own sink, then the sparse results merge.
  std::vector<std::vector<BoxCount>> parts(static_cast<std::size_t>(nt));
  std::vector<std::uint64_t> expanded(static_cast<std::size_t>(nt), 0);
  std::mutex error_mutex;
  std::exception_ptr error;
  std::atomic<bool> failed{false};
#pragma omp parallel num_threads(nt)
  {
    const int t = omp_get_thread_num();
    try {
      SourceSink& sink = local_sink(ns);
      const SinkGuard guard{sink};
      NodeMap nodes(kNoNode);
      auto& buf = local_buffer(slice);
      // Static partition of the slices by hand (no worksharing construct, so an exception in
      // one thread cannot leave the others waiting at a barrier).
      const std::int64_t team = omp_get_num_threads();
      const std::int64_t z0 = box.lo.z + s.z * t / team, z1 = box.lo.z + s.z * (t + 1) / team;
      for (std::int64_t z = z0; z < z1 && !failed.load(std::memory_order_relaxed); ++z) {
        grid_.decode_box(0, {{box.lo.x, box.lo.y, z}, {box.hi.x, box.hi.y, z + 1}}, {buf.data(), slice});
        accumulate_unit(buf.data(), slice, ns, sink, nodes);
      }
      expanded[std::size_t(t)] = sink.expand(nodes, lookup_, ns);
      sink.drain(parts[std::size_t(t)]);
    } catch (...) {
      std::lock_guard lock(error_mutex);
      if (!error) error = std::current_exception();
      failed = true;
    }
  }
  if (error) std::rethrow_exception(error);
  // The parts merge through this thread's sink, in thread order: counts add, variances add
  // (sigma = sqrt of the summed sigma^2), and drain() sorts the sources.
  SourceSink& sink = local_sink(ns);
  const SinkGuard guard{sink};
  for (const auto& part : parts)
    for (const BoxCount& c : part) sink.add(c);
  sink.drain(result.counts);
  for (auto e : expanded) result.distinct_nodes += e;  // per thread (a node may count twice)
  return result;
}

}  // namespace strata::mixture
