#include "strata/mixture/histogram_mipmap.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::mixture {

namespace {

constexpr double kExactLimit = 9007199254740992.0;  // 2^53

// One parent whose children differ: its canonical mixture, waiting to be interned.
struct Pending {
  std::uint64_t voxel;
  std::uint64_t offset;
  std::uint32_t length;
  std::uint64_t hash;
};

struct SliceBuffer {
  std::vector<Pending> pending;
  std::vector<std::uint32_t> index;
  std::vector<double> mass;
  void clear() {
    pending.clear();
    index.clear();
    mass.clear();
  }
};

// Canonical mixture of the average of `n` child mixtures (ids c[0..n), any order) into out.
void combine_children(const MixtureTable& table, std::uint32_t* c, int n, std::vector<SparseEntry>& scratch,
                      SliceBuffer& out, std::uint64_t voxel) {
  for (int i = 1; i < n; ++i)  // insertion sort of <= 8 ids
    for (int j = i; j > 0 && c[j - 1] > c[j]; --j) std::swap(c[j - 1], c[j]);
  scratch.clear();
  const bool integral = table.integral();
  std::uint64_t lcm = 1;
  if (integral) {
    for (int i = 0; i < n; ++i) {
      if (i > 0 && c[i] == c[i - 1]) continue;
      lcm = std::lcm(lcm, std::uint64_t(table.total(c[i])));
      if (double(lcm) * n > kExactLimit)
        throw Error("histogram mipmap: exact counts exceed 2^53 (volume too large for exact rational weights)");
    }
  }
  for (int i = 0; i < n;) {
    const std::uint32_t id = c[i];
    int r = 0;
    while (i < n && c[i] == id) ++r, ++i;
    const double f = integral ? double(std::uint64_t(r) * (lcm / std::uint64_t(table.total(id)))) : double(r) / table.total(id);
    const auto ix = table.index(id);
    const auto ms = table.mass(id);
    for (std::size_t k = 0; k < ix.size(); ++k) scratch.push_back({ix[k], ms[k] * f});
  }
  std::sort(scratch.begin(), scratch.end(), [](const SparseEntry& a, const SparseEntry& b) { return a.index < b.index; });
  const std::uint64_t offset = out.index.size();
  for (std::size_t i = 0; i < scratch.size();) {
    SparseEntry e = scratch[i++];
    while (i < scratch.size() && scratch[i].index == e.index) e.weight += scratch[i++].weight;
    out.index.push_back(e.index);
    out.mass.push_back(e.weight);
  }
  const std::uint32_t length = std::uint32_t(out.index.size() - offset);
  std::span<double> mass(out.mass.data() + offset, length);
  MixtureTable::canonicalize(mass, integral);
  const std::uint64_t hash = MixtureTable::hash_of({out.index.data() + offset, length}, mass);
  out.pending.push_back({voxel, offset, length, hash});
}

}  // namespace

std::vector<Extent> mip_level_dims(Extent d) {
  if (d.x <= 0 || d.y <= 0 || d.z <= 0) throw Error("histogram mipmap: dims must be positive, got " + d.to_string());
  std::vector<Extent> out{d};
  while (d.x > 1 || d.y > 1 || d.z > 1) {
    d = {(d.x + 1) / 2, (d.y + 1) / 2, (d.z + 1) / 2};
    out.push_back(d);
  }
  return out;
}

HistogramMipmap HistogramMipmap::from_source_ids(Extent dims, std::vector<std::uint32_t> ids, std::uint32_t num_sources,
                                                 ProgressSink& progress) {
  if (std::int64_t(ids.size()) != dims.voxel_count())
    throw Error("histogram mipmap: " + std::to_string(ids.size()) + " source ids for dims " + dims.to_string());
  for (std::uint32_t id : ids)
    if (id >= num_sources)
      throw Error("histogram mipmap: source id " + std::to_string(id) + " >= number of sources " + std::to_string(num_sources));
  HistogramMipmap h;
  h.fractional_ = false;
  h.table_ = MixtureTable(num_sources, true);
  h.levels_.push_back({dims, std::move(ids)});
  h.build_levels(progress);
  h.count_multiplicities({});
  return h;
}

HistogramMipmap HistogramMipmap::from_labels(const Volume& labels, LabelMap* map, ProgressSink& progress) {
  SourceIds s = to_source_ids(labels);
  const std::uint32_t n = s.map.size();
  if (map) *map = s.map;
  return from_source_ids(s.dims, std::move(s.ids), n, progress);
}

HistogramMipmap HistogramMipmap::from_fractional(const FractionalVoxels& in, ProgressSink& progress) {
  const std::int64_t voxels = in.dims.voxel_count();
  if (in.dims.x <= 0 || in.dims.y <= 0 || in.dims.z <= 0)
    throw Error("histogram mipmap: dims must be positive, got " + in.dims.to_string());
  if (std::int64_t(in.offsets.size()) != voxels + 1 || in.offsets.back() != in.index.size() ||
      in.index.size() != in.weight.size())
    throw Error("histogram mipmap: fractional input: offsets/index/weight sizes do not match dims " + in.dims.to_string());
  HistogramMipmap h;
  h.fractional_ = true;
  h.table_ = MixtureTable(in.num_sources, false);
  MipLevel l0{in.dims, std::vector<std::uint32_t>(std::size_t(voxels))};
  std::vector<SparseEntry> e;
  std::vector<std::uint32_t> ix;
  std::vector<double> ms;
  for (std::int64_t v = 0; v < voxels; ++v) {
    e.clear();
    for (std::uint64_t k = in.offsets[std::size_t(v)]; k < in.offsets[std::size_t(v) + 1]; ++k) {
      if (in.index[k] >= in.num_sources)
        throw Error("histogram mipmap: fractional input: voxel " + std::to_string(v) + ": index " +
                    std::to_string(in.index[k]) + " >= number of sources " + std::to_string(in.num_sources));
      e.push_back({in.index[k], in.weight[k]});
    }
    SparseMixture m = SparseMixture::from_entries(e);
    if (m.empty()) throw Error("histogram mipmap: fractional input: voxel " + std::to_string(v) + " has no positive weight");
    if (m.nnz() == 1) {
      l0.ids[std::size_t(v)] = m[0].index;
      continue;
    }
    ix.clear();
    ms.clear();
    for (const auto& x : m.entries()) ix.push_back(x.index), ms.push_back(x.weight);
    MixtureTable::canonicalize(ms, false);
    l0.ids[std::size_t(v)] = h.table_.intern(ix, ms, 0, std::uint64_t(v));
  }
  h.levels_.push_back(std::move(l0));
  h.build_levels(progress);
  h.count_multiplicities({});
  return h;
}

namespace {

// Parent slices [z0, z1) of a level of dims P from its children (dims C), whose slices from
// `child_z0` on start at `child`; the ids go to `parent`, which holds the parent slices from
// `parent_z0` on. New mixtures record their whole-level voxel index. Batches of
// slices are combined in parallel, then interned sequentially in z order, so the table (and
// everything downstream) is the same whatever the batches or the slabs that feed them.
void build_parent_slices(MixtureTable& table, const std::uint32_t* child, std::int64_t child_z0, Extent C, Extent P,
                         std::int64_t z0, std::int64_t z1, int level, std::uint32_t* parent, std::int64_t parent_z0,
                         ProgressTask* task) {
  const std::uint64_t held_from = std::uint64_t(parent_z0 * P.y * P.x);
  const int nt = thread_count();
  const std::int64_t batch = std::max<std::int64_t>(1, std::min<std::int64_t>(z1 - z0, 4 * nt));
  std::vector<SliceBuffer> buffers(static_cast<std::size_t>(batch));
  std::string error;  // exceptions must not leave an OpenMP region
  for (std::int64_t b0 = z0; b0 < z1; b0 += batch) {
    const std::int64_t b1 = std::min(z1, b0 + batch);
#pragma omp parallel num_threads(nt)
    {
      std::vector<SparseEntry> scratch;
#pragma omp for schedule(dynamic, 1)
      for (std::int64_t z = b0; z < b1; ++z) {
        SliceBuffer& out = buffers[std::size_t(z - b0)];
        out.clear();
        const std::int64_t cz0 = 2 * z, cz1 = std::min(C.z, 2 * z + 2);
        for (std::int64_t y = 0; y < P.y; ++y) {
          const std::int64_t cy0 = 2 * y, cy1 = std::min(C.y, 2 * y + 2);
          for (std::int64_t x = 0; x < P.x; ++x) {
            const std::int64_t cx0 = 2 * x, cx1 = std::min(C.x, 2 * x + 2);
            std::uint32_t c[8] = {};
            int n = 0;
            for (std::int64_t cz = cz0; cz < cz1; ++cz)
              for (std::int64_t cy = cy0; cy < cy1; ++cy) {
                const std::uint32_t* row = child + ((cz - child_z0) * C.y + cy) * C.x;
                for (std::int64_t cx = cx0; cx < cx1; ++cx) c[n++] = row[cx];
              }
            const std::uint64_t v = std::uint64_t((z * P.y + y) * P.x + x);
            bool same = true;
            for (int i = 1; i < n; ++i) same = same && c[i] == c[0];
            if (same) {
              parent[v - held_from] = c[0];
            } else {
              try {
                combine_children(table, c, n, scratch, out, v);
              } catch (const std::exception& e) {
#pragma omp critical(strata_mixture_mipmap_error)
                error = e.what();
              }
            }
          }
        }
      }
    }
    if (!error.empty()) throw Error(error);
    for (std::int64_t z = b0; z < b1; ++z) {
      const SliceBuffer& b = buffers[std::size_t(z - b0)];
      for (const Pending& p : b.pending)
        parent[p.voxel - held_from] = table.intern({b.index.data() + p.offset, p.length}, {b.mass.data() + p.offset, p.length},
                                       p.hash, level, p.voxel);
    }
    if (task) task->advance(std::uint64_t((b1 - b0) * P.y * P.x));
  }
}

}  // namespace

void HistogramMipmap::build_levels(ProgressSink& progress) {
  const auto dims = mip_level_dims(levels_[0].dims);
  std::uint64_t total = 0;
  for (std::size_t l = levels_.size(); l < dims.size(); ++l) total += std::uint64_t(dims[l].voxel_count());
  ProgressTask task(progress, "histogram mipmap", total, "voxels");
  for (std::size_t l = levels_.size(); l < dims.size(); ++l) {
    const Extent P = dims[l];
    const Extent C = dims[l - 1];
    MipLevel level{P, std::vector<std::uint32_t>(std::size_t(P.voxel_count()))};
    build_parent_slices(table_, levels_[l - 1].ids.data(), 0, C, P, 0, P.z, int(l), level.ids.data(), 0, &task);
    levels_.push_back(std::move(level));
  }
}

void HistogramMipmap::count_multiplicities(std::span<const std::uint64_t> streamed_level0) {
  std::vector<std::uint64_t> m(table_.size(), 0);
  for (const auto& L : levels_)
    for (std::uint32_t id : L.ids) ++m[id];
  for (std::size_t id = 0; id < streamed_level0.size(); ++id) m[id] += streamed_level0[id];
  table_.set_multiplicities(std::move(m));
  table_.compact();  // complete: nothing is interned any more
}

// ---------------------------------------------------------------------------------------------
// StreamBuilder

HistogramMipmap::StreamBuilder::StreamBuilder(Extent dims, std::uint32_t num_sources)
    : StreamBuilder(dims, num_sources, 0, dims.z) {}

HistogramMipmap::StreamBuilder::StreamBuilder(Extent dims, std::uint32_t num_sources, std::int64_t z_begin,
                                              std::int64_t z_end)
    : dims_(mip_level_dims(dims)), z_begin_(z_begin), z_end_(z_end), slices_(z_begin) {
  if (z_begin < 0 || z_begin % 2 != 0 || z_end < z_begin || z_end > dims.z)
    throw Error("histogram mipmap: slices [" + std::to_string(z_begin) + ", " + std::to_string(z_end) +
                ") are not a range of dims " + dims.to_string() + " starting at an even slice");
  h_.fractional_ = false;
  h_.table_ = MixtureTable(num_sources, true);
  level0_counts_.assign(num_sources, 0);
  h_.levels_.push_back({dims, {}});
  if (dims_.size() > 1) {
    const Extent& P = dims_[1];
    const std::int64_t held = (z_end + 1) / 2 - z_begin / 2;
    h_.levels_.push_back({P, std::vector<std::uint32_t>(std::size_t(held * P.y * P.x))});
  }
}

void HistogramMipmap::StreamBuilder::append(std::span<const std::uint32_t> ids) {
  const Extent C = dims_[0];
  const std::size_t slice = std::size_t(C.x * C.y);
  const std::int64_t n = std::int64_t(ids.size() / slice);
  if (ids.size() % slice != 0 || slices_ + n > z_end_)
    throw Error("histogram mipmap: " + std::to_string(ids.size()) + " ids after slice " + std::to_string(slices_) +
                " are not whole slices within slices [" + std::to_string(z_begin_) + ", " + std::to_string(z_end_) +
                ") of dims " + C.to_string());
  if (slices_ % 2 != 0)
    throw Error("histogram mipmap: a slab after an odd number of slices (" + std::to_string(slices_) +
                "); only the last slab may be odd");
  const std::uint32_t sources = h_.table_.num_sources();
  for (const std::uint32_t id : ids) {
    if (id >= sources)
      throw Error("histogram mipmap: source id " + std::to_string(id) + " >= number of sources " + std::to_string(sources));
    ++level0_counts_[id];
  }
  const std::int64_t z0 = slices_;
  slices_ += n;
  if (dims_.size() < 2 || n == 0) return;
  build_parent_slices(h_.table_, ids.data(), z0, C, dims_[1], z0 / 2, (slices_ + 1) / 2, 1, h_.levels_[1].ids.data(),
                      z_begin_ / 2, nullptr);
}

void HistogramMipmap::StreamBuilder::append_part(const MipmapSlabPart& part) {
  const std::uint32_t sources = h_.table_.num_sources();
  const std::size_t mixtures = part.first_voxel.size();
  const std::int64_t level1_slices = dims_.size() > 1 ? (part.z_end + 1) / 2 - part.z_begin / 2 : 0;
  const std::int64_t level1_area = dims_.size() > 1 ? dims_[1].x * dims_[1].y : 0;
  if (part.z_begin != slices_ || slices_ % 2 != 0 || part.z_end < part.z_begin || part.z_end > z_end_ ||
      part.level0_counts.size() != sources || part.offsets.size() != mixtures + 1 ||
      part.index.size() != part.offsets.back() || part.mass.size() != part.index.size() ||
      part.level1_ids.size() != std::size_t(level1_slices * level1_area))
    throw Error("histogram mipmap: a part of slices [" + std::to_string(part.z_begin) + ", " +
                std::to_string(part.z_end) + ") does not continue slice " + std::to_string(slices_) + " of dims " +
                dims_[0].to_string() + " (or its arrays disagree)");
  // Local id -> id in this table: sources are shared, new mixtures are interned in local order.
  std::vector<std::uint32_t> global(sources + mixtures);
  for (std::uint32_t id = 0; id < sources; ++id) global[id] = id;
  for (std::size_t k = 0; k < mixtures; ++k) {
    const std::uint64_t at = part.offsets[k], end = part.offsets[k + 1];
    if (end < at || end > part.index.size())
      throw Error("histogram mipmap: a part's mixture offsets are not ascending");
    const std::span<const std::uint32_t> index(part.index.data() + at, std::size_t(end - at));
    const std::span<const double> mass(part.mass.data() + at, std::size_t(end - at));
    for (const std::uint32_t i : index)
      if (i >= sources) throw Error("histogram mipmap: a part's mixture holds source id " + std::to_string(i));
    global[sources + k] = h_.table_.intern(index, mass, 1, part.first_voxel[k]);
  }
  // Level 1 holds slices from z_begin_ / 2 on; the part's start there.
  std::uint32_t* out =
      level1_slices > 0 ? h_.levels_[1].ids.data() + (part.z_begin - z_begin_) / 2 * level1_area : nullptr;
  for (std::size_t v = 0; v < part.level1_ids.size(); ++v) {
    const std::uint32_t id = part.level1_ids[v];
    if (id >= global.size()) throw Error("histogram mipmap: a part's level-1 id " + std::to_string(id) + " is unknown");
    out[v] = global[id];
  }
  for (std::uint32_t id = 0; id < sources; ++id) level0_counts_[id] += part.level0_counts[id];
  slices_ = part.z_end;
}

HistogramMipmap HistogramMipmap::StreamBuilder::finish(ProgressSink& progress) {
  if (z_begin_ != 0 || z_end_ != dims_[0].z || slices_ != z_end_)
    throw Error("histogram mipmap: " + std::to_string(slices_ - z_begin_) + " slices streamed for dims " +
                dims_[0].to_string());
  h_.build_levels(progress);
  h_.count_multiplicities(level0_counts_);
  level0_counts_.clear();
  return std::move(h_);
}

MipmapSlabPart HistogramMipmap::StreamBuilder::finish_part() {
  if (slices_ != z_end_)
    throw Error("histogram mipmap: a part of slices [" + std::to_string(z_begin_) + ", " + std::to_string(z_end_) +
                ") ends at slice " + std::to_string(slices_));
  MipmapSlabPart part;
  part.z_begin = z_begin_;
  part.z_end = z_end_;
  const MixtureTable& t = h_.table_;
  for (std::uint32_t id = t.num_sources(); id < t.size(); ++id) {
    part.index.insert(part.index.end(), t.index(id).begin(), t.index(id).end());
    part.mass.insert(part.mass.end(), t.mass(id).begin(), t.mass(id).end());
    part.offsets.push_back(part.index.size());
    part.first_voxel.push_back(t.first_voxel(id));
  }
  if (h_.levels_.size() > 1) part.level1_ids = std::move(h_.levels_[1].ids);
  part.level0_counts = std::move(level0_counts_);
  h_ = {};
  return part;
}

MipmapStats HistogramMipmap::stats() const {
  MipmapStats s;
  for (std::uint32_t id = 0; id < table_.size(); ++id) {
    const std::uint64_t mult = table_.multiplicity(id);
    if (mult == 0) continue;
    const std::uint64_t k = table_.nnz(id);
    ++s.distinct_mixtures;
    s.voxels += mult;
    s.nnz_total += mult * k;
    s.input_pairs += k * (k - 1) / 2;
    s.voxel_pairs += mult * (k * (k - 1) / 2);
    s.max_nnz = std::max<std::uint32_t>(s.max_nnz, std::uint32_t(k));
  }
  s.nnz_per_voxel = s.voxels ? double(s.nnz_total) / double(s.voxels) : 0.0;
  return s;
}

}  // namespace strata::mixture
