// Greedy factorisation of distinct mixtures into 2-element interpolations.
//
// Data structures (all incremental - a step never rescans the mixture set):
//   work      every distinct mixture being factorised, as (node id, mass) entries sorted by
//             id in one CSR arena; a merge removes two entries and appends the new node (its
//             id is larger than every id present), so a mixture shrinks in place and stays
//             sorted. Masses are integer counts for single-label input, so every ratio
//             w = m_b / (m_a + m_b) is computed from exact numbers.
//   postings  node id -> work mixtures it was added to. Entries go stale when the node is
//             merged away; they are dropped lazily when the list is scanned. A step scans
//             the SHORTER of the two lists and checks the other id by binary search.
//   pairs     (a, b) -> {hits, distinct bins, phi, combined mass}, over the mixtures that
//             currently vote. Updated per merged mixture: pairs with a or b are removed, pairs
//             with the new node added - O(nnz). phi2 additionally changes for every pair of a
//             mixture whose nnz term changes (nnz > 3): O(nnz^2), bounded by the dense cut.
//   bins      (a, b, bin) -> count, which yields the distinct-bin count of each pair.
//   heap      max-heap of (score key, pair) with lazy invalidation: an entry is pushed when a
//             pair's key increases; a popped entry whose key is out of date is re-pushed with
//             the current key if that is lower (or dropped if the pair is gone or higher).
//             The heap therefore always holds an entry >= every live pair's key, and an
//             up-to-date top is a true maximum.
//   Two stages (§3.7): first only mixtures with nnz > tau vote (smaller ones are still
//   merged whenever a chosen pair occurs in them); then every mixture with nnz >= 2 votes.
#include "strata/mixture/factorize.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include <unistd.h>

#include "strata/core/check.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/io/files.hpp"
#include "strata/mixture/flat_hash.hpp"
#include "strata/mixture/schedule.hpp"

namespace strata::mixture {

namespace {

// The one name table of the pair scores: the short name (library, tests), the paper's strategy
// name (CLI, file metadata) and the formula it implements.
struct PairScoreNames {
  PairScore score;
  std::string_view name, strategy, formula;
};
constexpr PairScoreNames kPairScoreNames[] = {{PairScore::occurrence, "occurrence", "max-occurrence", "phi1"},
                                              {PairScore::reduction, "reduction", "max-reduction", "phi2"},
                                              {PairScore::reuse, "reuse", "reuse", "reuse"}};

const PairScoreNames& names_of(PairScore s) {
  for (const PairScoreNames& n : kPairScoreNames)
    if (n.score == s) return n;
  throw Error("pair score: invalid value " + std::to_string(int(s)));
}

}  // namespace

std::string_view pair_score_name(PairScore s) { return names_of(s).name; }
std::string_view strategy_name(PairScore s) { return names_of(s).strategy; }

PairScore parse_pair_score(std::string_view name) {
  for (const PairScoreNames& n : kPairScoreNames)
    if (name == n.name || name == n.strategy || name == n.formula) return n.score;
  throw Error("pair score: expected max-reduction, max-occurrence or reuse (or reduction, occurrence, phi2, phi1), got '" +
              std::string(name) + "'");
}

std::string_view weight_bins_name(WeightBins b) { return b == WeightBins::uniform ? "uniform" : "symmetric"; }

WeightBins parse_weight_bins(std::string_view name) {
  if (name == "symmetric") return WeightBins::symmetric;
  if (name == "uniform") return WeightBins::uniform;
  throw Error("weight bins: expected symmetric or uniform, got '" + std::string(name) + "'");
}

std::uint32_t quantize_weight(double w, int bits, WeightBins layout) {
  const std::uint32_t n = 1u << bits;
  if (layout == WeightBins::uniform) {
    const double scaled = w * double(n);
    if (!(scaled > 0.0)) return 0;
    return scaled >= double(n - 1) ? n - 1 : std::uint32_t(scaled);
  }
  const double r = std::nearbyint(w * double(2 * n));
  if (!(r > 1.0)) return 0;
  return r >= double(n) ? n - 1 : std::uint32_t(r) - 1;
}

double bin_center(std::uint32_t q, int bits, WeightBins layout) {
  const double n = double(1u << bits);
  return layout == WeightBins::uniform ? (double(q) + 0.5) / n : (double(q) + 1.0) / (2.0 * n);
}

std::pair<double, double> bin_range(std::uint32_t q, int bits, WeightBins layout) {
  const std::uint32_t n = 1u << bits;
  if (layout == WeightBins::uniform) return {double(q) / n, double(q + 1) / n};
  const double lo = q == 0 ? 0.0 : (double(q) + 0.5) / (2.0 * n);
  const double hi = q + 1 == n ? 0.5 : (double(q) + 1.5) / (2.0 * n);
  return {lo, hi};
}

Interpolation orient(std::uint32_t x, std::uint32_t y, double mx, double my, int bits, WeightBins layout) {
  Interpolation r;
  const bool y_is_b = layout == WeightBins::uniform ? x < y : (my < mx || (my == mx && x < y));
  if (y_is_b) {
    r.a = x, r.b = y, r.w = my / (mx + my);
  } else {
    r.a = y, r.b = x, r.w = mx / (mx + my);
  }
  r.bin = quantize_weight(r.w, bits, layout);
  return r;
}

void validate(const MixtureGraph& g) {
  const std::uint32_t bins = std::uint32_t(1) << g.codebook.bits;
  if (g.codebook.value.size() != bins || g.codebook.sigma.size() != bins)
    throw Error("mixture graph: codebook has " + std::to_string(g.codebook.value.size()) + " values and " +
                std::to_string(g.codebook.sigma.size()) + " sigmas, expected " + std::to_string(bins) + " each");
  const bool symmetric = g.codebook.layout == WeightBins::symmetric;
  for (std::uint32_t q = 0; q < bins; ++q) {
    const double w = g.codebook.value[q], s = g.codebook.sigma[q];
    if (!(w > 0.0 && (symmetric ? w <= 0.5 : w < 1.0)))
      throw Error("mixture graph: codebook weight " + std::to_string(q) + " is " + std::to_string(w) +
                  (symmetric ? ", expected in (0, 0.5]" : ", expected in (0, 1)"));
    if (!(s >= 0.0 && std::isfinite(s)))
      throw Error("mixture graph: codebook sigma " + std::to_string(q) + " is " + std::to_string(s) +
                  ", expected finite and >= 0");
  }
  for (std::size_t i = 0; i < g.nodes.size(); ++i) {
    const InternalNode& n = g.nodes[i];
    const std::uint64_t id = std::uint64_t(g.num_sources) + i;
    if (n.a == n.b || n.a >= id || n.b >= id)
      throw Error("mixture graph: node " + std::to_string(id) + " has predecessors (" + std::to_string(n.a) + ", " +
                  std::to_string(n.b) + "), expected two distinct earlier nodes");
    if (n.bin >= bins)
      throw Error("mixture graph: node " + std::to_string(id) + " uses weight bin " + std::to_string(n.bin) +
                  ", expected < " + std::to_string(bins));
  }
}

namespace {

constexpr std::uint32_t kNone = ~0u;

std::uint64_t pair_key(std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; }

// A node (or a pair's bin) by its predecessor pair and bin. Three u32 rather than a u64 and a
// u32: 12 bytes with 4-byte alignment, so a hash slot with its u32 value is 16 bytes, not 24
// (the node and bin maps of a large factorisation hold tens of millions of slots).
struct NodeKey {
  std::uint32_t hi, lo, bin;
  NodeKey(std::uint64_t pair, std::uint32_t bin_) : hi(std::uint32_t(pair >> 32)), lo(std::uint32_t(pair)), bin(bin_) {}
  std::uint64_t pair() const { return (std::uint64_t(hi) << 32) | lo; }
  bool operator==(const NodeKey&) const = default;
};
static_assert(sizeof(detail::FlatMap<NodeKey, std::uint32_t>::Slot) == 16);
struct NodeKeyHash {
  std::uint64_t operator()(const NodeKey& k) const { return splitmix64(k.pair() ^ (std::uint64_t(k.bin) << 47) ^ k.bin); }
};

// Nodes, their dedupe map and the per-bin statistics of the codebook.
class NodeStore {
 public:
  NodeStore(std::uint32_t num_sources, int bits, WeightBins layout)
      : num_sources_(num_sources), bits_(bits), layout_(layout), map_(NodeKey{~0ULL, 0}),
        use_count_(std::size_t(1) << bits, 0), sum_d_(std::size_t(1) << bits, 0.0), sum_d2_(std::size_t(1) << bits, 0.0),
        min_d_(std::size_t(1) << bits, std::numeric_limits<double>::infinity()),
        max_d_(std::size_t(1) << bits, -std::numeric_limits<double>::infinity()) {}

  // The canonical node merging x (mass mx) and y (mass my); records the use of its bin.
  std::uint32_t merge(std::uint32_t x, std::uint32_t y, double mx, double my, std::uint64_t mult, bool* reused) {
    STRATA_DEBUG_CHECK(x != y && x < next_id() && y < next_id(),
                       "mixture factorisation merges nodes " + std::to_string(x) + " and " + std::to_string(y) +
                           ": predecessors must be distinct existing nodes (next id " + std::to_string(next_id()) + ")");
    STRATA_DEBUG_CHECK(mx > 0.0 && my > 0.0 && std::isfinite(mx + my),
                       "mixture factorisation merges masses " + std::to_string(mx) + " and " + std::to_string(my) +
                           ": both must be positive and finite");
    const Interpolation it = orient(x, y, mx, my, bits_, layout_);
    const std::uint32_t q = it.bin;
    const double d = it.w - bin_center(q, bits_, layout_);
    use_count_[q] += mult;
    sum_d_[q] += double(mult) * d;
    sum_d2_[q] += double(mult) * d * d;
    min_d_[q] = std::min(min_d_[q], d);
    max_d_[q] = std::max(max_d_[q], d);
    auto [slot, inserted] = map_.insert(NodeKey{pair_key(it.a, it.b), q}, 0);
    if (inserted) {
      *slot = num_sources_ + std::uint32_t(nodes_.size());
      if (*slot == kNone) throw Error("mixture graph: more than 2^32 - 1 nodes");
      nodes_.push_back({it.a, it.b, q});
    }
    *reused = !inserted;
    return *slot;
  }

  std::uint32_t next_id() const { return num_sources_ + std::uint32_t(nodes_.size()); }
  std::vector<InternalNode>& nodes() { return nodes_; }

  Codebook codebook() const {
    Codebook c;
    c.bits = bits_;
    c.layout = layout_;
    const std::size_t n = std::size_t(1) << bits_;
    c.value.resize(n);
    c.sigma.assign(n, 0.0);
    c.uses = use_count_;
    for (std::size_t q = 0; q < n; ++q) {
      const double centre = bin_center(std::uint32_t(q), bits_, layout_);
      if (use_count_[q] == 0) {
        c.value[q] = centre;
        continue;
      }
      const double mean_d = sum_d_[q] / double(use_count_[q]);
      const double spread = std::sqrt(std::max(0.0, sum_d2_[q] / double(use_count_[q]) - mean_d * mean_d));
      c.value[q] = centre + mean_d;
      const double max_deviation = std::max(max_d_[q] - mean_d, mean_d - min_d_[q]);
      c.sigma[q] = std::max(spread, max_deviation / std::sqrt(3.0));
    }
    return c;
  }

 private:
  std::uint32_t num_sources_;
  int bits_;
  WeightBins layout_;
  detail::FlatMap<NodeKey, std::uint32_t, NodeKeyHash> map_;
  std::vector<InternalNode> nodes_;
  std::vector<std::uint64_t> use_count_;
  std::vector<double> sum_d_, sum_d2_;  // deviations from the bin centre (no cancellation)
  std::vector<double> min_d_, max_d_;   // their range (empty bins: +inf, -inf)
};

struct PairStat {
  std::uint32_t hits = 0;      // voting mixtures holding the pair
  std::uint32_t distinct = 0;  // distinct weight bins among them
  std::uint64_t phi = 0;       // phi1 or phi2 (multiplicity weighted)
  std::uint64_t mass = 0;      // sum of (m_a + m_b) / total in 2^-30 units
};

struct HeapEntry {
  std::uint64_t primary, secondary, tertiary;  // larger is better
  std::uint64_t pair;                          // smaller is better
  bool operator==(const HeapEntry&) const = default;
};
bool operator<(const HeapEntry& x, const HeapEntry& y) {
  if (x.primary != y.primary) return x.primary < y.primary;
  if (x.secondary != y.secondary) return x.secondary < y.secondary;
  if (x.tertiary != y.tertiary) return x.tertiary < y.tertiary;
  return x.pair > y.pair;
}

struct Work {
  std::uint64_t offset;
  std::uint32_t length;
  std::uint32_t table_id;
  std::uint64_t mult;
  double total;
  bool voter;
};

std::uint64_t g_reduction(std::uint32_t nnz) { return nnz > 2 ? nnz - 1 : (nnz == 2 ? 2 : 0); }

class Greedy {
 public:
  Greedy(const FactorOptions& o, NodeStore& store, std::uint32_t num_sources)
      : opt_(o), store_(store), postings_(num_sources), pairs_(~0ULL), bins_(NodeKey{~0ULL, 0}) {}

  void add(std::uint32_t table_id, std::span<const std::uint32_t> index, std::span<const double> mass,
           std::uint64_t mult) {
    Work w{index_.size(), std::uint32_t(index.size()), table_id, std::max<std::uint64_t>(1, mult), 0.0, false};
    for (double m : mass) w.total += m;
    const std::uint32_t k = std::uint32_t(work_.size());
    for (std::size_t i = 0; i < index.size(); ++i) {
      index_.push_back(index[i]);
      mass_.push_back(mass[i]);
      postings_[index[i]].push_back(k);
    }
    total_merges_ += index.size() - 1;
    work_.push_back(w);
  }

  std::uint64_t total_merges() const { return total_merges_; }

  void run(ProgressTask& task) {
    task_ = &task;
    if (opt_.tau >= 2) {
      stage_lo_ = opt_.tau;
      vote_and_search();
    }
    stage_lo_ = 1;
    vote_and_search();
    for (const Work& w : work_)
      if (w.length != 1) throw Error("mixture factorisation: internal error, a mixture was left unfactored");
  }

  // After run(): the node of each work mixture, in insertion order.
  std::uint32_t result(std::size_t k) const { return index_[work_[k].offset]; }
  std::uint32_t table_id(std::size_t k) const { return work_[k].table_id; }
  std::size_t size() const { return work_.size(); }
  std::uint64_t steps() const { return steps_; }
  std::uint64_t merges() const { return merges_; }
  std::uint64_t reused() const { return reused_; }

 private:
  HeapEntry key_of(const PairStat& s, std::uint64_t pair) const {
    const std::uint64_t saved = s.hits - s.distinct;
    if (opt_.score == PairScore::reuse) return {saved, s.phi, ~s.mass, pair};
    return {s.phi, saved, ~s.mass, pair};
  }

  void push(const HeapEntry& e) {
    heap_.push_back(e);
    std::push_heap(heap_.begin(), heap_.end());
  }

  std::uint64_t phi_weight(const Work& w, std::uint32_t nnz) const {
    return opt_.score == PairScore::reduction ? w.mult * g_reduction(nnz) : w.mult;
  }

  // Adds (sign > 0) or removes the contribution of one pair of mixture w.
  void contribute(const Work& w, std::uint32_t x, std::uint32_t y, double mx, double my, std::uint64_t phi, int sign,
                  bool push_on_increase) {
    if (x > y) std::swap(x, y), std::swap(mx, my);
    const std::uint64_t key = pair_key(x, y);
    // The node this pair would become: bin and orientation identify it within the pair.
    const Interpolation it = orient(x, y, mx, my, opt_.bits, opt_.bins);
    const std::uint32_t bin = 2 * it.bin + (it.a == x ? 0u : 1u);
    const std::uint64_t mass = std::uint64_t(std::llround((mx + my) / w.total * 1073741824.0));
    if (sign > 0) {
      auto [bc, bnew] = bins_.insert(NodeKey{key, bin}, 0);
      ++*bc;
      auto [st, inserted] = pairs_.insert(key, PairStat{});
      const HeapEntry before = key_of(*st, key);
      st->hits += 1;
      st->distinct += bnew ? 1 : 0;
      st->phi += phi;
      st->mass += mass;
      if (push_on_increase && (inserted || before < key_of(*st, key))) push(key_of(*st, key));
    } else {
      std::uint32_t* bc = bins_.find(NodeKey{key, bin});
      PairStat* st = pairs_.find(key);
      if (!bc || !st) throw Error("mixture factorisation: internal error, missing pair statistics");
      const bool last_of_bin = --*bc == 0;
      if (last_of_bin) bins_.erase(NodeKey{key, bin});
      st->hits -= 1;
      st->distinct -= last_of_bin ? 1 : 0;
      st->phi -= phi;
      st->mass -= mass;
      if (st->hits == 0) pairs_.erase(key);
    }
  }

  void all_pairs(const Work& w, int sign, bool push_on_increase) {
    const std::uint32_t* ix = index_.data() + w.offset;
    const double* ms = mass_.data() + w.offset;
    const std::uint64_t phi = phi_weight(w, w.length);
    for (std::uint32_t i = 0; i < w.length; ++i)
      for (std::uint32_t j = i + 1; j < w.length; ++j) contribute(w, ix[i], ix[j], ms[i], ms[j], phi, sign, push_on_increase);
  }

  void vote_and_search() {
    pairs_.clear();
    bins_.clear();
    heap_.clear();
    for (Work& w : work_) {
      w.voter = w.length > stage_lo_;
      if (w.voter) all_pairs(w, +1, false);
    }
    heap_.reserve(pairs_.size());
    pairs_.for_each([&](std::uint64_t key, const PairStat& s) { heap_.push_back(key_of(s, key)); });
    std::make_heap(heap_.begin(), heap_.end());
    while (!heap_.empty()) {
      std::pop_heap(heap_.begin(), heap_.end());
      const HeapEntry top = heap_.back();
      heap_.pop_back();
      const PairStat* st = pairs_.find(top.pair);
      if (!st) continue;
      const HeapEntry current = key_of(*st, top.pair);
      if (!(current == top)) {
        if (current < top) push(current);
        continue;
      }
      apply(std::uint32_t(top.pair >> 32), std::uint32_t(top.pair));
    }
  }

  // Position of id in mixture k, or kNone.
  std::uint32_t find(const Work& w, std::uint32_t id) const {
    const std::uint32_t* b = index_.data() + w.offset;
    const std::uint32_t* e = b + w.length;
    const std::uint32_t* it = std::lower_bound(b, e, id);
    return (it != e && *it == id) ? std::uint32_t(it - b) : kNone;
  }

  void apply(std::uint32_t a, std::uint32_t b) {
    ++steps_;
    const bool a_shorter = postings_[a].size() <= postings_[b].size();
    const std::uint32_t scan = a_shorter ? a : b, other = a_shorter ? b : a;
    auto& list = postings_[scan];
    affected_.clear();
    std::size_t keep = 0;
    for (std::uint32_t k : list) {
      const Work& w = work_[k];
      if (find(w, scan) == kNone) continue;  // stale
      list[keep++] = k;
      if (find(w, other) != kNone) affected_.push_back(k);
    }
    list.resize(keep);
    for (std::uint32_t k : affected_) merge_in(k, a, b);
    task_->advance(affected_.size());
  }

  void merge_in(std::uint32_t k, std::uint32_t a, std::uint32_t b) {
    Work& w = work_[k];
    std::uint32_t* ix = index_.data() + w.offset;
    double* ms = mass_.data() + w.offset;
    const std::uint32_t ia = find(w, a), ib = find(w, b);
    const double ma = ms[ia], mb = ms[ib];
    bool reused = false;
    const std::uint32_t n = store_.merge(a, b, ma, mb, w.mult, &reused);
    ++merges_;
    reused_ += reused ? 1 : 0;
    if (n >= postings_.size()) postings_.resize(std::size_t(n) + 1);
    const std::uint32_t old_len = w.length, new_len = old_len - 1;
    const bool stays_voter = w.voter && new_len > stage_lo_;
    if (w.voter) {
      if (!stays_voter) {
        all_pairs(w, -1, false);
      } else {
        const std::uint64_t phi_old = phi_weight(w, old_len);
        contribute(w, a, b, ma, mb, phi_old, -1, false);
        for (std::uint32_t i = 0; i < old_len; ++i) {
          if (i == ia || i == ib) continue;
          contribute(w, a, ix[i], ma, ms[i], phi_old, -1, false);
          contribute(w, b, ix[i], mb, ms[i], phi_old, -1, false);
        }
        const std::uint64_t phi_new = phi_weight(w, new_len);
        if (phi_new != phi_old) {  // phi2: every remaining pair's nnz term drops
          const std::uint64_t delta = phi_old - phi_new;
          for (std::uint32_t i = 0; i < old_len; ++i) {
            if (i == ia || i == ib) continue;
            for (std::uint32_t j = i + 1; j < old_len; ++j) {
              if (j == ia || j == ib) continue;
              PairStat* st = pairs_.find(pair_key(ix[i], ix[j]));
              if (!st) throw Error("mixture factorisation: internal error, missing pair statistics");
              st->phi -= delta;  // a decrease: the heap entry stays an upper bound
            }
          }
        }
      }
    }
    // Shrink in place: drop a and b, append n (the largest id present).
    std::uint32_t out = 0;
    for (std::uint32_t i = 0; i < old_len; ++i) {
      if (i == ia || i == ib) continue;
      ix[out] = ix[i];
      ms[out] = ms[i];
      ++out;
    }
    ix[out] = n;
    ms[out] = ma + mb;
    w.length = new_len;
    if (new_len > 1) postings_[n].push_back(k);  // a finished mixture takes part in no more merges
    w.voter = stays_voter;
    if (stays_voter) {
      const std::uint64_t phi_new = phi_weight(w, new_len);
      for (std::uint32_t i = 0; i + 1 < new_len; ++i) contribute(w, ix[i], n, ms[i], ma + mb, phi_new, +1, true);
    }
  }

  const FactorOptions& opt_;
  NodeStore& store_;
  std::vector<Work> work_;
  std::vector<std::uint32_t> index_;
  std::vector<double> mass_;
  std::vector<std::vector<std::uint32_t>> postings_;
  detail::FlatMap<std::uint64_t, PairStat> pairs_;
  detail::FlatMap<NodeKey, std::uint32_t, NodeKeyHash> bins_;
  std::vector<HeapEntry> heap_;
  std::vector<std::uint32_t> affected_;
  std::uint32_t stage_lo_ = 1;
  std::uint64_t total_merges_ = 0, steps_ = 0, merges_ = 0, reused_ = 0;
  ProgressTask* task_ = nullptr;
};

void check_options(const FactorOptions& o) {
  if (o.bits < 1 || o.bits > 16) throw Error("mixture factorisation: bits must be in 1..16, got " + std::to_string(o.bits));
}

using NodeCounts = std::vector<std::pair<std::uint64_t, std::uint32_t>>;  // (count, node)

// Into `out`: the nodes of the <= 8 children of dense mixture `id` (at its first voxel), with how
// many children hold each, ascending node.
void children_of(const MixtureTable& table, const std::vector<MipLevel>& levels,
                 const std::vector<std::uint32_t>& node_of_mixture, std::uint32_t id, NodeCounts& out) {
  const int l = table.first_level(id);
  const MipLevel& P = levels[std::size_t(l)];
  const MipLevel& C = levels[std::size_t(l) - 1];
  const std::uint64_t v = table.first_voxel(id);
  const std::int64_t x = std::int64_t(v % std::uint64_t(P.dims.x));
  const std::int64_t y = std::int64_t((v / std::uint64_t(P.dims.x)) % std::uint64_t(P.dims.y));
  const std::int64_t z = std::int64_t(v / std::uint64_t(P.dims.x * P.dims.y));
  std::uint32_t child[8] = {};
  int n = 0;
  for (std::int64_t cz = 2 * z; cz < std::min(C.dims.z, 2 * z + 2); ++cz)
    for (std::int64_t cy = 2 * y; cy < std::min(C.dims.y, 2 * y + 2); ++cy)
      for (std::int64_t cx = 2 * x; cx < std::min(C.dims.x, 2 * x + 2); ++cx) {
        const std::uint32_t node = node_of_mixture[C.ids[C.index(cx, cy, cz)]];
        if (node == kNone) throw Error("mixture factorisation: internal error, child without a node");
        child[n++] = node;
      }
  for (int i = 1; i < n; ++i)  // insertion sort of <= 8 node ids
    for (int j = i; j > 0 && child[j - 1] > child[j]; --j) std::swap(child[j - 1], child[j]);
  out.clear();
  for (int i = 0; i < n;) {
    const std::uint32_t node = child[i];
    std::uint64_t c = 0;
    while (i < n && child[i] == node) ++c, ++i;
    out.push_back({c, node});
  }
}

// Eq. 4 as interpolations: merges the children's nodes smallest count first (Huffman-like)
// into one node. A merge may return a node that already exists (the store dedupes on (pair,
// bin)), and that node can be one of the pending children itself: e.g. children A, B and
// C = (A, B, bin) where A and B, merged with their counts, fall in C's bin. The two copies of C
// then describe the same mixture, so their counts add up in one entry; merging C with itself
// would make a node with equal predecessors (a self-loop in the DAG).
// Consumes `pending`.
std::uint32_t merge_children(NodeCounts& pending, std::uint64_t mult, NodeStore& store, FactorStats& stats) {
  auto smallest = [&]() {
    const auto it = std::min_element(pending.begin(), pending.end());
    const auto p = *it;
    pending.erase(it);
    return p;
  };
  while (pending.size() > 1) {
    const auto p = smallest();
    const auto q = smallest();
    bool reused = false;
    const std::uint32_t node = store.merge(p.second, q.second, double(p.first), double(q.first), mult, &reused);
    ++stats.merges;
    stats.reused += reused ? 1 : 0;
    const std::uint64_t count = p.first + q.first;
    const auto same = std::find_if(pending.begin(), pending.end(), [&](const auto& e) { return e.second == node; });
    if (same != pending.end()) {
      same->first += count;
    } else {
      pending.push_back({count, node});
    }
  }
  return pending.front().second;
}

// The mip levels' ids, parked in an unnamed temporary file while the greedy search holds its
// tables, so that the two largest structures of an encoding never share memory.
class ParkedLevels {
 public:
  ParkedLevels(std::vector<MipLevel>& levels, const std::filesystem::path& dir)
      : levels_(levels), file_(dir, ".strata-mip-levels") {
    for (MipLevel& L : levels_) {
      file_.write(L.ids.data(), L.ids.size() * sizeof(std::uint32_t));
      counts_.push_back(L.ids.size());
      L.ids = {};
    }
  }

  void restore() {
    off_t at = 0;
    for (std::size_t l = 0; l < levels_.size(); ++l) {
      std::vector<std::uint32_t>& ids = levels_[l].ids;
      ids.resize(counts_[l]);
      auto* bytes = reinterpret_cast<char*>(ids.data());
      std::size_t left = ids.size() * sizeof(std::uint32_t);
      while (left > 0) {
        const ssize_t n = ::pread(file_.descriptor(), bytes, left, at);
        if (n <= 0) throw Error("mixture factorisation: cannot read back the mip levels parked in " + file_.dir().string());
        bytes += n, left -= std::size_t(n), at += n;
      }
    }
  }

 private:
  std::vector<MipLevel>& levels_;
  io::UnnamedTempFile file_;
  std::vector<std::size_t> counts_;
};

// Shared driver. `levels` (mixture ids per voxel) enables the dense shortcut; may be null.
// With opt.park_dir set they wait in a temporary file there during the greedy search.
Factorization run_factorize(const MixtureTable& table, std::vector<MipLevel>* levels, const FactorOptions& opt,
                            ProgressSink& progress) {
  check_options(opt);
  const auto t0 = std::chrono::steady_clock::now();
  const std::uint32_t N = table.num_sources();
  Factorization f;
  f.graph.num_sources = N;
  f.node_of_mixture.assign(table.size(), kNone);
  NodeStore store(N, opt.bits, opt.bins);

  std::vector<std::uint32_t> dense;
  {
    std::optional<Greedy> greedy(std::in_place, opt, store, N);
    for (std::uint32_t id = 0; id < table.size(); ++id) {
      const std::uint32_t k = table.nnz(id);
      f.stats.input_pairs += std::uint64_t(k) * (k - 1) / 2;
      if (k == 1) {
        f.node_of_mixture[id] = table.index(id)[0];
        continue;
      }
      // A streamed mipmap holds no level-0 ids, so level-1 mixtures cannot be rebuilt from their
      // children there (with the default threshold they never qualify: 8 children give nnz <= 8).
      const bool use_children = levels && opt.dense_threshold > 0 && k > opt.dense_threshold &&
                                table.first_level(id) > 0 && table.first_voxel(id) != MixtureTable::kNoVoxel &&
                                !(*levels)[std::size_t(table.first_level(id)) - 1].ids.empty();
      if (use_children) {
        dense.push_back(id);
      } else {
        greedy->add(id, table.index(id), table.mass(id), table.multiplicity(id));
      }
    }
    f.stats.greedy_mixtures = greedy->size();
    f.stats.dense_mixtures = dense.size();
    std::optional<ParkedLevels> parked;
    if (levels && !opt.park_dir.empty()) parked.emplace(*levels, opt.park_dir);
    {
      ProgressTask task(progress, "factorize", greedy->total_merges(), "merges");
      greedy->run(task);
    }
    for (std::size_t k = 0; k < greedy->size(); ++k) f.node_of_mixture[greedy->table_id(k)] = greedy->result(k);
    f.stats.steps = greedy->steps();
    f.stats.merges = greedy->merges();
    f.stats.reused = greedy->reused();
    if (parked) {
      greedy.reset();  // its tables go before the levels come back
      parked->restore();
    }
  }

  // Dense mixtures: average of the children's nodes, coarse levels after finer ones.
  std::stable_sort(dense.begin(), dense.end(),
                   [&](std::uint32_t x, std::uint32_t y) { return table.first_level(x) < table.first_level(y); });
  NodeCounts children;  // reused: one dense mixture after another
  for (std::uint32_t id : dense) {
    const std::uint64_t mult = std::max<std::uint64_t>(1, table.multiplicity(id));
    children_of(table, *levels, f.node_of_mixture, id, children);
    f.node_of_mixture[id] = merge_children(children, mult, store, f.stats);
  }
  f.graph.nodes = std::move(store.nodes());
  f.graph.codebook = store.codebook();
  f.stats.internal_nodes = f.graph.nodes.size();
  f.stats.nodes = f.graph.node_count();
#ifndef NDEBUG
  validate(f.graph);
#endif
  f.stats.depth = topological_depth(f.graph);
  f.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return f;
}

void remap_levels(std::vector<MipLevel>& levels, const std::vector<std::uint32_t>& node_of_mixture) {
  for (auto& L : levels) {
    auto& ids = L.ids;
#pragma omp parallel for num_threads(thread_count()) schedule(static)
    for (std::int64_t i = 0; i < std::int64_t(ids.size()); ++i) ids[std::size_t(i)] = node_of_mixture[ids[std::size_t(i)]];
  }
}

}  // namespace

Factorization factorize(const HistogramMipmap& h, const FactorOptions& options, ProgressSink& progress) {
  std::vector<MipLevel> levels = h.levels();
  Factorization f = run_factorize(h.table(), &levels, options, progress);
  f.levels = std::move(levels);
  remap_levels(f.levels, f.node_of_mixture);
  return f;
}

Factorization factorize(HistogramMipmap&& h, const FactorOptions& options, ProgressSink& progress) {
  std::vector<MipLevel> levels = h.release_levels();
  Factorization f = run_factorize(h.table(), &levels, options, progress);
  f.levels = std::move(levels);
  remap_levels(f.levels, f.node_of_mixture);
  return f;
}

Factorization factorize(const MixtureTable& table, const FactorOptions& options, ProgressSink& progress) {
  return run_factorize(table, nullptr, options, progress);
}

}  // namespace strata::mixture
