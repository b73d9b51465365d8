#include "strata/core/stopwatch.hpp"
#include "strata/ta/compress.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>

#include "strata/core/error.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/target_codec.hpp"
#include "ta/level_pipeline.hpp"
#include "ta/metadata.hpp"

namespace strata::ta {

namespace {

using Clock = std::chrono::steady_clock;
HistogramRange value_range(io::VolumeSource& source, ProgressSink& progress, std::uint64_t slab_bytes) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  io::for_each_slab(source, [&](const Volume& slab, std::int64_t) {
    visit_dtype(slab.dtype(), [&](auto tag) {
      using T = decltype(tag);
      const auto values = slab.samples<T>();
      if (values.empty()) return;
      if constexpr (std::is_floating_point_v<T>) {
        // A NaN would slip through min/max and poison every decomposition it touches.
        for (T v : values)
          if (!std::isfinite(v))
            throw Error(source.path().string() + ": samples: NaN or infinite values cannot be compressed");
      }
      // Branch-free min/max in the sample type (vectorised), widened once per slab.
      T mn = values[0], mx = values[0];
      for (T v : values) {
        mn = v < mn ? v : mn;
        mx = v > mx ? v : mx;
      }
      lo = std::min(lo, double(mn));
      hi = std::max(hi, double(mx));
    });
  }, progress, "scan range", slab_bytes);
  if (!std::isfinite(lo) || !std::isfinite(hi))
    throw Error(source.path().string() + ": samples: NaN or infinite values cannot be compressed");
  return {lo, hi};
}

// Converts each slice straight into the float vector the pipeline keeps (one pass, no float
// copy of the whole slab).
void push_slab_to_level0(const Volume& slab, LevelPipeline& level0) {
  const std::size_t slice = std::size_t(slab.dims().x * slab.dims().y);
  visit_dtype(slab.dtype(), [&](auto tag) {
    using T = decltype(tag);
    const auto samples = slab.samples<T>();
    for (std::int64_t z = 0; z < slab.dims().z; ++z) {
      const T* src = samples.data() + std::size_t(z) * slice;
      level0.push_slice(std::vector<float>(src, src + slice));
    }
  });
}

// Allowance for everything not proportional to the volume: code, per-thread brick scratch,
// container index entries, allocator slack.
constexpr std::uint64_t kBaselineBytes = 48ull << 20;

}  // namespace

std::uint64_t fixed_working_set(const OctreeGeometry& geometry) {
  const BrickLayout& l = geometry.layout();
  std::uint64_t bytes = 0;
  for (int level = 0; level < geometry.level_count(); ++level) {
    const Extent& d = geometry.level(level).dims;
    const std::uint64_t slice = std::uint64_t(d.x * d.y) * sizeof(float);
    bytes += slice * std::uint64_t(l.brick + 1 + l.core() + 1);  // window + decoded row + pending pair
  }
  return bytes;
}

std::uint64_t input_slab_bytes(const OctreeGeometry& geometry, const VolumeInfo& source, const CompressParams& params) {
  if (params.memory_limit == 0) return io::kDefaultSlabBytes;
  const std::uint64_t fixed = fixed_working_set(geometry) + kBaselineBytes;
  // A slab is held in the source type plus its per-slice float copies while pushed.
  const double per_source_byte = 1.0 + double(sizeof(float)) / double(dtype_size(source.dtype));
  const std::uint64_t slice = source.bytes_per_slice();
  const std::uint64_t needed = fixed + std::uint64_t(double(slice) * per_source_byte);
  if (params.memory_limit < needed)
    throw ParameterError("CompressParams::memory_limit", "compressing " + source.dims.to_string() + " with brick " +
                                                             std::to_string(params.layout.brick) + " needs at least " +
                                                             std::to_string(needed >> 20) + " MiB");
  const auto budget = std::uint64_t(double(params.memory_limit - fixed) / per_source_byte);
  return std::min<std::uint64_t>(io::kDefaultSlabBytes, std::max(budget, slice));
}

CompressReport compress_volume(io::VolumeSource& source, const std::filesystem::path& out,
                               const CompressParams& params, ProgressSink& progress) {
  const auto start = Clock::now();
  const VolumeInfo& info = source.info();
  if (params.codec.rank < 1 || params.codec.rank > params.layout.brick)
    throw ParameterError("CodecParams::rank", "must be between 1 and the brick width " + std::to_string(params.layout.brick) +
                                                  ", got " + std::to_string(params.codec.rank));
  check_target(params.codec.target);
  const OctreeGeometry geometry(info.dims, params.layout);
  CompressReport report;
  report.input_voxels = std::uint64_t(info.dims.voxel_count());
  report.levels.resize(std::size_t(geometry.level_count()));

  const std::uint64_t slab_bytes = input_slab_bytes(geometry, info, params);
  const HistogramRange range = value_range(source, progress, slab_bytes);
  report.prepass_seconds = seconds_since(start);

  std::vector<BrickTarget> targets;
  if (params.codec.target.kind != TargetKind::none)
    targets = level_targets(params.codec.target, range.lo, range.hi, geometry.level_count(), params.codec.rank,
                            params.codec.zstd_level);
  store::ContainerWriter writer(out);
  std::mutex report_mutex;
  ProgressTask bricks_task(progress, "compress", std::uint64_t(geometry.total_bricks()), "bricks");
  BrickSink sink = [&](const store::BrickKey& key, const EncodedBrick& b, float lo, float hi, std::uint64_t hist) {
    store::BrickEntry entry{key, b.kind, 0, 0, 0, lo, hi, hist};
    if (b.kind == store::PayloadKind::constant) entry.min = entry.max = b.constant_value;
    writer.add_brick(entry, b.payload);
    {
      std::lock_guard lock(report_mutex);
      LevelCounts& counts = report.levels[key.level];
      ++counts.bricks;
      counts.constant += b.kind == store::PayloadKind::constant;
      report.core_bytes += b.core_bytes;
      report.factor_bytes += b.factor_bytes;
      report.brick_header_bytes += b.header_bytes;
    }
    bricks_task.advance(1);
  };

  // Coarsest level first so each level can point at its parent-level pipeline.
  std::vector<std::unique_ptr<LevelPipeline>> levels(std::size_t(geometry.level_count()));
  for (int l = geometry.level_count() - 1; l >= 0; --l) {
    LevelPipeline* next = l + 1 < geometry.level_count() ? levels[std::size_t(l + 1)].get() : nullptr;
    const std::optional<BrickTarget> target =
        targets.empty() ? std::nullopt : std::optional<BrickTarget>(targets[std::size_t(l)]);
    levels[std::size_t(l)] = std::make_unique<LevelPipeline>(geometry, l, params.codec, target, range, sink, next);
  }
  io::for_each_slab(source, [&](const Volume& slab, std::int64_t) { push_slab_to_level0(slab, *levels[0]); },
                    silent_progress(), "read", slab_bytes);
  levels[0]->finish();

  report.file_bytes = writer.finish(make_metadata(info, geometry, params, range, targets));
  report.container_bytes = report.file_bytes - report.core_bytes - report.factor_bytes - report.brick_header_bytes;
  report.seconds = seconds_since(start);
  return report;
}

}  // namespace strata::ta
