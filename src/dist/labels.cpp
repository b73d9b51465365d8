#include "strata/dist/labels.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <exception>
#include <optional>
#include <type_traits>

#include "dist/transfer.hpp"
#include "mixture/encode_steps.hpp"
#include "strata/core/error.hpp"
#include "strata/dist/agree.hpp"
#include "strata/mixture/histogram_mipmap.hpp"

namespace strata::dist {

namespace {

using mixture::HistogramMipmap;
using mixture::LabelMap;
using mixture::MipmapSlabPart;
using mixture::detail::Level0Ids;

// One label map from every rank's values: their union, ascending (the map a single process
// gathers over the whole volume).
LabelMap all_gather_map(MPI_Comm comm, DType dtype, const LabelMap& mine) {
  const int ranks = comm_size(comm);
  const long long count = mine.size();
  std::vector<long long> counts(static_cast<std::size_t>(ranks), 0);
  MPI_Allgather(&count, 1, MPI_LONG_LONG, counts.data(), 1, MPI_LONG_LONG, comm);
  long long total = 0;
  for (const long long c : counts) total += c;
  if (total > INT_MAX)  // the same on every rank: all throw
    throw Error("distributed label encoding: the ranks found " + std::to_string(total) +
                " label values together, more than one MPI gather holds (2^31 - 1)");
  std::vector<int> sizes(static_cast<std::size_t>(ranks)), at(sizes.size());
  for (int r = 0, offset = 0; r < ranks; ++r) {
    sizes[std::size_t(r)] = int(counts[std::size_t(r)]);
    at[std::size_t(r)] = offset;
    offset += sizes[std::size_t(r)];
  }
  static_assert(std::is_same_v<std::int64_t, long> || std::is_same_v<std::int64_t, long long>);
  std::vector<std::int64_t> values(static_cast<std::size_t>(total));
  MPI_Allgatherv(mine.values().data(), int(count), MPI_INT64_T, values.data(), sizes.data(), at.data(), MPI_INT64_T,
                 comm);
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  return LabelMap(dtype, std::move(values));
}

// A rank's part: level-0 ids (serialized), and level 1 with its mixtures.
struct Part {
  std::vector<std::byte> level0;
  MipmapSlabPart mipmap;

  std::uint64_t bytes() const {
    const MipmapSlabPart& m = mipmap;
    return level0.size() + 8 * (m.offsets.size() + m.mass.size() + m.first_voxel.size() + m.level0_counts.size()) +
           4 * (m.index.size() + m.level1_ids.size()) + 16;
  }
};

void send_part(MPI_Comm comm, const Part& p) {
  const MipmapSlabPart& m = p.mipmap;
  const std::int64_t range[2] = {m.z_begin, m.z_end};
  send_array<std::int64_t>(comm, 0, range);
  send_array<std::byte>(comm, 0, p.level0);
  send_array<std::uint64_t>(comm, 0, m.offsets);
  send_array<std::uint32_t>(comm, 0, m.index);
  send_array<double>(comm, 0, m.mass);
  send_array<std::uint64_t>(comm, 0, m.first_voxel);
  send_array<std::uint32_t>(comm, 0, m.level1_ids);
  send_array<std::uint64_t>(comm, 0, m.level0_counts);
}

Part receive_part(MPI_Comm comm, int from) {
  Part p;
  MipmapSlabPart& m = p.mipmap;
  const std::vector<std::int64_t> range = receive_array<std::int64_t>(comm, from);
  if (range.size() == 2) m.z_begin = range[0], m.z_end = range[1];
  p.level0 = receive_array<std::byte>(comm, from);
  m.offsets = receive_array<std::uint64_t>(comm, from);
  m.index = receive_array<std::uint32_t>(comm, from);
  m.mass = receive_array<double>(comm, from);
  m.first_voxel = receive_array<std::uint64_t>(comm, from);
  m.level1_ids = receive_array<std::uint32_t>(comm, from);
  m.level0_counts = receive_array<std::uint64_t>(comm, from);
  return p;
}

class Run {
 public:
  Run(MPI_Comm comm, const std::filesystem::path& input, const io::ReadOptions& read, const std::filesystem::path& out,
      const mixture::EncodeOptions& options, ProgressSink& progress)
      : comm_(comm),
        rank_(comm_rank(comm)),
        ranks_(comm_size(comm)),
        out_(out),
        options_(options),
        progress_(rank_ == 0 ? progress : silent_progress()) {
    agree_on(comm_, [&] {
      if (options_.normals)
        throw ParameterError("EncodeOptions::normals",
                             "distributed label encoding cannot store a normals graph: the normals are estimated over "
                             "the whole volume on one process; use `strata labels encode --normals`");
      mixture::validate(options_);
      source_ = io::open_volume(input, read);
      const VolumeInfo& info = source_->info();
      mixture::require_label_dtype(input.string(), info.dtype);
      slab_ = mixture::label_slab_slices(info, options_.memory_limit);
    });
    const VolumeInfo& info = source_->info();
    own_ = label_slices_of(info.dims.z, rank_, ranks_);
    report_.dims = info.dims;
    stats_.z_begin = own_.begin;
    stats_.z_end = own_.end;
    stats_.input_bytes = 2 * std::uint64_t(own_.size()) * info.bytes_per_slice();
  }

  DistributedLabelsReport run() {
    const auto start = std::chrono::steady_clock::now();
    double t = MPI_Wtime();
    LabelMap mine(source_->info().dtype, {});
    agree_on(comm_, [&] {
      if (own_.size() > 0) mine = mixture::detail::collect_label_map(*source_, own_, slab_, progress_);
    });
    LabelMap map = all_gather_map(comm_, source_->info().dtype, mine);
    stats_.values_seconds = MPI_Wtime() - t;

    t = MPI_Wtime();
    std::optional<Part> part;
    agree_on(comm_, [&] {
      if (own_.size() > 0) part = encode_part(map);
    });
    stats_.ids_seconds = MPI_Wtime() - t;

    t = MPI_Wtime();
    std::optional<HistogramMipmap::StreamBuilder> mipmap;
    std::optional<Level0Ids> level0;
    merge_parts(map, std::move(part), mipmap, level0);
    stats_.merge_seconds = MPI_Wtime() - t;

    t = MPI_Wtime();
    agree_on(comm_, [&] {
      if (rank_ != 0) return;
      mixture::detail::StreamedLabels s =
          mixture::detail::finish_streamed(std::move(map), *mipmap, *level0, options_, progress_);
      mipmap.reset();
      report_.report =
          mixture::detail::write_labels_file(std::move(s), source_->info(), nullptr, out_, options_, progress_, start);
    });
    stats_.write_seconds = MPI_Wtime() - t;
    report_.ranks = gather_to_root(comm_, stats_);
    return std::move(report_);
  }

 private:
  // This rank's slices as source ids: its part of level 0's id storage and of level 1.
  Part encode_part(const LabelMap& map) {
    const Extent& dims = source_->info().dims;
    HistogramMipmap::StreamBuilder mipmap(dims, map.size(), own_.begin, own_.end);
    Level0Ids level0({dims.x, dims.y, own_.size()}, map.size(), options_.ids);
    mixture::detail::stream_ids(*source_, own_, slab_, map, mipmap, level0, progress_);
    Part p{level0.part_bytes(), mipmap.finish_part()};
    stats_.part_mixtures = p.mipmap.first_voxel.size();
    stats_.part_bytes = p.bytes();
    return p;
  }

  // Rank 0 takes the parts in z order (its own first) into the builders of the whole volume;
  // the others send theirs. After a failure rank 0 still receives every part, so no rank waits
  // forever; the failure is agreed at the end.
  void merge_parts(const LabelMap& map, std::optional<Part> own, std::optional<HistogramMipmap::StreamBuilder>& mipmap,
                   std::optional<Level0Ids>& level0) {
    std::exception_ptr error;
    if (rank_ != 0) {
      if (own) send_part(comm_, *own);
      agree(comm_, error);
      return;
    }
    const Extent& dims = source_->info().dims;
    try {
      mipmap.emplace(dims, map.size());
      level0.emplace(dims, map.size(), options_.ids);
    } catch (...) {
      error = std::current_exception();
    }
    ProgressTask task(progress_, "merge parts", std::uint64_t(ranks_), "ranks");
    for (int r = 0; r < ranks_; ++r) {
      if (label_slices_of(dims.z, r, ranks_).size() > 0) {
        Part p = r == 0 ? std::move(*own) : receive_part(comm_, r);
        if (!error) {
          try {
            mipmap->append_part(p.mipmap);
            level0->append_part(p.level0);
          } catch (...) {
            error = std::current_exception();
          }
        }
      }
      task.advance(1);
    }
    agree(comm_, error);
  }

  MPI_Comm comm_;
  int rank_, ranks_;
  std::filesystem::path out_;
  mixture::EncodeOptions options_;
  ProgressSink& progress_;
  std::unique_ptr<io::VolumeSource> source_;
  std::int64_t slab_ = 0;
  io::SliceSpan own_;
  LabelRankStats stats_;
  DistributedLabelsReport report_;
};

}  // namespace

io::SliceSpan label_slices_of(std::int64_t depth, int rank, int ranks) {
  const std::int64_t row = mixture::BlockPaletteIds::kBlock;
  const std::int64_t rows = (depth + row - 1) / row;
  auto start = [&](int k) { return std::min(depth, rows * k / ranks * row); };
  return {start(rank), start(rank + 1)};
}

DistributedLabelsReport encode_labels_distributed(MPI_Comm comm, const std::filesystem::path& input,
                                                  const io::ReadOptions& read, const std::filesystem::path& out,
                                                  const mixture::EncodeOptions& options, ProgressSink& progress) {
  Run run(comm, input, read, out, options, progress);
  return run.run();
}

}  // namespace strata::dist
