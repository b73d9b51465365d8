#include "strata/dist/compress.hpp"

#include <algorithm>
#include <climits>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <optional>

#include "dist/transfer.hpp"
#include "strata/core/progress.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/codec_registry.hpp"
#include "ta/compress_steps.hpp"
#include "ta/level_pipeline.hpp"
#include "ta/metadata.hpp"

namespace strata::dist {

namespace {

// Slices [begin, end) of one level.
using SliceRange = io::SliceSpan;

SliceRange intersect(const SliceRange& a, const SliceRange& b) {
  return {std::max(a.begin, b.begin), std::min(a.end, b.end)};
}

// The slices of `level` that rows `rows` read: their cores plus the overlap, clamped.
SliceRange input_slices(const ta::OctreeGeometry& g, int level, const RowRange& rows) {
  if (rows.empty()) return {};
  const ta::BrickLayout& l = g.layout();
  return {std::max<std::int64_t>(0, rows.begin * l.core() - l.overlap),
          std::min(g.level(level).dims.z, rows.end * l.core() + l.overlap)};
}

// The slices of `level` that rows `rows` own (their cores).
SliceRange core_slices(const ta::OctreeGeometry& g, int level, const RowRange& rows) {
  if (rows.empty()) return {};
  return {rows.begin * g.layout().core(), std::min(g.level(level).dims.z, rows.end * g.layout().core())};
}

// The slices of level + 1 that rows `rows` of `level` make (each 2x2x2 block of decoded voxels
// is one voxel of the next level; an odd last slice stands for itself).
SliceRange produced_slices(const ta::OctreeGeometry& g, int level, const RowRange& rows) {
  const SliceRange c = core_slices(g, level, rows);
  if (c.size() == 0) return {};
  return {c.begin / 2, (c.end + 1) / 2};
}

// One brick as rank 0 writes it: the index entry's fields, then the payload.
struct BrickRecord {
  std::int32_t x, y, z;
  std::uint8_t level, kind, pad[2];
  float min, max;
  std::uint64_t histogram, payload_bytes;
};

void append_brick(std::vector<std::byte>& blob, const store::BrickEntry& e, std::span<const std::byte> payload) {
  const BrickRecord r{e.key.x,    e.key.y,    e.key.z,     e.key.level, std::uint8_t(e.kind), {},
                      e.min,      e.max,      e.histogram, std::uint64_t(payload.size())};
  const std::size_t at = blob.size();
  blob.resize(at + sizeof r + payload.size());
  std::memcpy(blob.data() + at, &r, sizeof r);
  if (!payload.empty()) std::memcpy(blob.data() + at + sizeof r, payload.data(), payload.size());
}

void write_bricks(store::ContainerWriter& writer, std::span<const std::byte> blob) {
  std::size_t at = 0;
  while (at < blob.size()) {
    BrickRecord r;
    std::memcpy(&r, blob.data() + at, sizeof r);
    at += sizeof r;
    store::BrickEntry e;
    e.key = store::BrickKey{r.level, r.x, r.y, r.z};
    e.kind = store::PayloadKind(r.kind);
    e.min = r.min;
    e.max = r.max;
    e.histogram = r.histogram;
    writer.add_brick(e, blob.subspan(at, std::size_t(r.payload_bytes)));
    at += std::size_t(r.payload_bytes);
  }
}

void check_distributable(const ta::CompressParams& params) {
  if (params.codec.target.kind != ta::TargetKind::none)
    throw ParameterError("ErrorTarget::kind",
                         "distributed compression is fixed-rank only: with an error target each brick's choice of "
                         "basis depends on the bricks of all earlier rows, and a PSNR/RMSE budget on a calibration "
                         "of the whole level, so no rank could reproduce its part of the single-process file");
  if (!ta::codec_for(params).distributed()) {
    std::string distributed;
    for (const ta::BrickCodec* c : ta::codecs())
      if (c->distributed()) distributed += std::string(distributed.empty() ? "" : ", ") + std::string(c->name());
    throw ParameterError("CompressParams::codec_name",
                         "distributed compression writes the " + distributed + " codec only: " + params.codec_name +
                             " does not encode each brick from its own samples alone (it fits the whole volume first)");
  }
}

// The per-rank state of one run.
class Run {
 public:
  Run(MPI_Comm comm, const std::filesystem::path& input, const io::ReadOptions& read, const std::filesystem::path& out,
      const ta::CompressParams& params)
      : comm_(comm), rank_(comm_rank(comm)), ranks_(comm_size(comm)), out_(out), params_(params) {
    agree_on(comm_, [&] {
      check_distributable(params_);
      ta::validate(params_);
      source_ = io::open_volume(input, read);
      geometry_.emplace(source_->info().dims, params_.layout);
      slab_bytes_ = ta::input_slab_bytes(*geometry_, source_->info(), params_);
      codec_run_ = ta::codec_for(params_).begin({*source_, params_, *geometry_, slab_bytes_, silent_progress()});
    });
    report_.report.levels.assign(std::size_t(geometry_->level_count()), ta::LevelCounts{});
    report_.report.input_voxels = std::uint64_t(source_->info().dims.voxel_count());
    stats_.level0_rows = rows(0).end - rows(0).begin;
  }

  DistributedReport run() {
    const double start = MPI_Wtime();
    scan_range();
    std::vector<float> slices;  // this rank's input slices of the current level (levels >= 1)
    for (int level = 0; level < geometry_->level_count(); ++level) {
      std::vector<float> produced;
      double t = MPI_Wtime();
      agree_on(comm_, [&] { encode_level(level, slices, produced); });
      stats_.encode_seconds += MPI_Wtime() - t;
      if (level + 1 == geometry_->level_count()) break;
      t = MPI_Wtime();
      slices = exchange(level, produced);
      stats_.exchange_seconds += MPI_Wtime() - t;
    }
    const double t = MPI_Wtime();
    write_file();
    stats_.write_seconds = MPI_Wtime() - t;
    finish_report(start);
    return std::move(report_);
  }

 private:
  RowRange rows(int level, int rank = -1) const {
    return rows_of(*geometry_, level, rank < 0 ? rank_ : rank, ranks_);
  }

  // Visits this rank's slices [range) of the input in slabs of the slab budget.
  void for_each_own_slab(const SliceRange& range, const std::function<void(const Volume&)>& visit) {
    const VolumeInfo& info = source_->info();
    io::for_each_slab(
        *source_, range, io::slices_per_slab(info, slab_bytes_),
        [&](const Volume& slab, std::int64_t) {
          stats_.input_bytes += std::uint64_t(slab.dims().z) * info.bytes_per_slice();
          visit(slab);
        },
        silent_progress(), "read");
  }

  // The value range over the whole volume: each rank scans its rows' cores, then a reduction.
  void scan_range() {
    const double t = MPI_Wtime();
    ta::RangeScan scan;
    agree_on(comm_, [&] {
      for_each_own_slab(core_slices(*geometry_, 0, rows(0)), [&](const Volume& slab) { scan.widen(slab); });
    });
    MPI_Allreduce(MPI_IN_PLACE, &scan.lo, 1, MPI_DOUBLE, MPI_MIN, comm_);
    MPI_Allreduce(MPI_IN_PLACE, &scan.hi, 1, MPI_DOUBLE, MPI_MAX, comm_);
    range_ = scan.range();
    agree_on(comm_, [&] { ta::check_codable(range_, source_->path(), params_); });
    stats_.scan_seconds = MPI_Wtime() - t;
  }

  // Encodes this rank's rows of `level` from its input slices (level 0: read from the input;
  // else `slices`, consumed), keeping the bricks for write_file() and the next level's slices
  // its rows make in `produced`.
  void encode_level(int level, std::vector<float>& slices, std::vector<float>& produced) {
    const RowRange own = rows(level);
    if (own.empty()) return;
    const bool last = level + 1 == geometry_->level_count();
    ta::BrickSink sink = [&](const store::BrickKey& key, const ta::EncodedBrick& b, float lo, float hi,
                             std::uint64_t histogram) {
      std::vector<std::byte>& blob = rows_[{key.level, key.z}];
      append_brick(blob, ta::index_entry(key, b, lo, hi, histogram), b.payload);
      ta::count_brick(report_.report, key, b);
      stats_.payload_bytes += b.payload.size();
      ++stats_.bricks;
    };
    ta::LevelPipeline pipeline(*geometry_, level, params_.codec, *codec_run_, std::nullopt, range_, sink, nullptr);
    pipeline.restrict_rows(own.begin, own.end);
    if (!last)
      pipeline.forward_slices(
          [&](std::vector<float> slice) { produced.insert(produced.end(), slice.begin(), slice.end()); });
    const SliceRange input = input_slices(*geometry_, level, own);
    if (level == 0) {
      for_each_own_slab(input, [&](const Volume& slab) { ta::push_slab_to_level0(slab, pipeline); });
    } else {
      const Extent& d = geometry_->level(level).dims;
      const std::size_t slice = std::size_t(d.x * d.y);
      for (std::int64_t z = 0; z < input.size(); ++z) {
        const float* s = slices.data() + std::size_t(z) * slice;
        pipeline.push_slice(std::vector<float>(s, s + slice));
      }
      slices = {};
    }
    pipeline.finish();
  }

  // The decoded-children exchange: rank j needs the slices of level + 1 that its rows read,
  // which the ranks whose rows of `level` cover them made. All ranges follow from the partition,
  // so one MPI_Alltoallv in units of one slice moves them.
  std::vector<float> exchange(int level, const std::vector<float>& produced) {
    const int next = level + 1;
    const Extent& d = geometry_->level(next).dims;
    const std::int64_t slice = d.x * d.y;
    if (slice > INT_MAX) throw Error("distributed compression: a slice of level " + std::to_string(next) +
                                     " holds more than 2^31 voxels (one MPI element)");
    MPI_Datatype slice_type;
    MPI_Type_contiguous(int(slice), MPI_FLOAT, &slice_type);
    MPI_Type_commit(&slice_type);
    const SliceRange mine = produced_slices(*geometry_, level, rows(level));
    const SliceRange need = input_slices(*geometry_, next, rows(next));
    const auto n = std::size_t(ranks_);
    std::vector<int> send_counts(n), send_at(n), receive_counts(n), receive_at(n);
    for (int j = 0; j < ranks_; ++j) {
      const SliceRange to = intersect(mine, input_slices(*geometry_, next, rows(next, j)));
      const SliceRange from = intersect(produced_slices(*geometry_, level, rows(level, j)), need);
      send_counts[std::size_t(j)] = int(to.size());
      send_at[std::size_t(j)] = to.size() ? int(to.begin - mine.begin) : 0;
      receive_counts[std::size_t(j)] = int(from.size());
      receive_at[std::size_t(j)] = from.size() ? int(from.begin - need.begin) : 0;
      if (j != rank_) {
        stats_.sent_bytes += std::uint64_t(to.size() * slice) * sizeof(float);
        stats_.received_bytes += std::uint64_t(from.size() * slice) * sizeof(float);
      }
    }
    std::vector<float> received(std::size_t(need.size() * slice));
    MPI_Alltoallv(produced.data(), send_counts.data(), send_at.data(), slice_type, received.data(),
                  receive_counts.data(), receive_at.data(), slice_type, comm_);
    MPI_Type_free(&slice_type);
    return received;
  }

  // Rank 0 writes the bricks in compress_volume's order, receiving each row from its rank; a
  // write error on rank 0 drops the file and drains the rest, so no rank waits forever.
  void write_file() {
    const std::vector<std::pair<int, std::int64_t>> order = row_order(*geometry_);
    auto owner = [&](int level, std::int64_t row) {
      for (int j = 0; j < ranks_; ++j) {
        const RowRange r = rows(level, j);
        if (row >= r.begin && row < r.end) return j;
      }
      return 0;
    };
    std::exception_ptr error;
    if (rank_ != 0) {
      for (const auto& [level, row] : order)
        if (owner(level, row) == rank_) {
          const auto it = rows_.find({std::uint8_t(level), std::int32_t(row)});
          send_array<std::byte>(comm_, 0, it->second);
          rows_.erase(it);
        }
    } else {
      std::unique_ptr<store::ContainerWriter> writer;
      try {
        writer = std::make_unique<store::ContainerWriter>(out_);
      } catch (...) {
        error = std::current_exception();
      }
      for (const auto& [level, row] : order) {
        const int from = owner(level, row);
        std::vector<std::byte> blob;
        if (from == 0) {
          const auto it = rows_.find({std::uint8_t(level), std::int32_t(row)});
          blob = std::move(it->second);
          rows_.erase(it);
        } else {
          blob = receive_array<std::byte>(comm_, from);
        }
        if (!writer) continue;
        try {
          write_bricks(*writer, blob);
        } catch (...) {
          error = std::current_exception();
          writer.reset();  // removes <out>.tmp
        }
      }
      if (writer) {
        try {
          // Counts of every rank for the report; the fixed-rank metadata does not hold them.
          nlohmann::json metadata = ta::make_metadata(source_->info(), *geometry_, params_, range_, {}, {});
          codec_run_->finish(*writer, metadata, report_.report);
          report_.report.file_bytes = writer->finish(std::move(metadata));
        } catch (...) {
          error = std::current_exception();
        }
      }
    }
    agree(comm_, error);
  }

  void finish_report(double start) {
    ta::CompressReport& r = report_.report;
    for (ta::LevelCounts& l : r.levels) {
      MPI_Allreduce(MPI_IN_PLACE, &l.bricks, 1, MPI_INT64_T, MPI_SUM, comm_);
      MPI_Allreduce(MPI_IN_PLACE, &l.constant, 1, MPI_INT64_T, MPI_SUM, comm_);
    }
    for (std::uint64_t* v : {&r.core_bytes, &r.factor_bytes, &r.brick_header_bytes})
      MPI_Allreduce(MPI_IN_PLACE, v, 1, MPI_UINT64_T, MPI_SUM, comm_);
    r.container_bytes = r.file_bytes - r.core_bytes - r.factor_bytes - r.brick_header_bytes;
    r.prepass_seconds = stats_.scan_seconds;
    r.seconds = MPI_Wtime() - start;
    report_.ranks = gather_to_root(comm_, stats_);
  }

  MPI_Comm comm_;
  int rank_, ranks_;
  std::filesystem::path out_;
  ta::CompressParams params_;
  std::unique_ptr<io::VolumeSource> source_;
  std::optional<ta::OctreeGeometry> geometry_;
  std::uint64_t slab_bytes_ = 0;
  std::unique_ptr<ta::CodecRun> codec_run_;  // the codec's encoder (fixed-rank ta-bricked)
  ta::HistogramRange range_;
  std::map<std::pair<std::uint8_t, std::int32_t>, std::vector<std::byte>> rows_;  // (level, row) -> bricks
  RankStats stats_;
  DistributedReport report_;
};

}  // namespace

RowRange rows_of(const ta::OctreeGeometry& geometry, int level, int rank, int ranks) {
  const std::int64_t rows = geometry.level(level).bricks.z;
  const std::int64_t unit = geometry.layout().core() % 2 ? 2 : 1;
  const std::int64_t units = (rows + unit - 1) / unit;
  auto start = [&](int k) { return std::min(rows, units * k / ranks * unit); };
  return {start(rank), start(rank + 1)};
}

std::vector<std::pair<int, std::int64_t>> row_order(const ta::OctreeGeometry& g) {
  // Replays the pipelines' counters: LevelPipeline::push_slice encodes each row as soon as its
  // slices are in, and a finished row hands the next level the slices it completes.
  const int levels = g.level_count();
  const std::int64_t core = g.layout().core(), overlap = g.layout().overlap;
  const auto n = std::size_t(levels);
  std::vector<std::int64_t> received(n), next_row(n), handed(n);
  std::vector<std::pair<int, std::int64_t>> order;
  std::function<void(int)> push;
  auto finish_row = [&](int l) {
    const std::int64_t row = next_row[std::size_t(l)], depth = g.level(l).dims.z;
    order.emplace_back(l, row);
    if (l + 1 < levels) {
      const std::int64_t z1 = std::min(depth, (row + 1) * core);
      const std::int64_t total = z1 == depth ? (depth + 1) / 2 : z1 / 2;
      while (handed[std::size_t(l)] < total) {
        ++handed[std::size_t(l)];
        push(l + 1);
      }
    }
    ++next_row[std::size_t(l)];
  };
  push = [&](int l) {
    const ta::LevelGeometry& lg = g.level(l);
    ++received[std::size_t(l)];
    while (next_row[std::size_t(l)] < lg.bricks.z &&
           received[std::size_t(l)] >= std::min(lg.dims.z, (next_row[std::size_t(l)] + 1) * core + overlap))
      finish_row(l);
  };
  for (std::int64_t z = 0; z < g.level(0).dims.z; ++z) push(0);
  for (int l = 0; l < levels; ++l)  // LevelPipeline::finish, level by level
    while (next_row[std::size_t(l)] < g.level(l).bricks.z) finish_row(l);
  return order;
}

DistributedReport compress_distributed(MPI_Comm comm, const std::filesystem::path& input, const io::ReadOptions& read,
                                       const std::filesystem::path& out, const ta::CompressParams& params) {
  Run run(comm, input, read, out, params);
  return run.run();
}

}  // namespace strata::dist
