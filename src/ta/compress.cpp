#include "strata/core/stopwatch.hpp"
#include "strata/ta/compress.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/target_codec.hpp"
#include "ta/compress_steps.hpp"
#include "ta/level_pipeline.hpp"
#include "ta/metadata.hpp"
#include "ta/step_calibration.hpp"

namespace strata::ta {

namespace {

using Clock = std::chrono::steady_clock;
// The value range, and the level-0 spectrum for `calibrator` when there is one.
HistogramRange value_range(io::VolumeSource& source, ProgressSink& progress, std::uint64_t slab_bytes,
                           StepCalibrator* calibrator) {
  RangeScan scan;
  io::for_each_slab(source, [&](const Volume& slab, std::int64_t) { scan.widen(slab, calibrator); }, progress,
                    "scan range", slab_bytes);
  return scan.range();
}

// The largest sample magnitude the codec takes: an orthonormal Tucker core of a B^3 brick holds
// up to B^(3/2) times the largest sample (its norm is the brick's), and it must stay a float,
// with a factor 2 to spare for the rounding of the decomposition.
double largest_codable_magnitude(int brick) {
  return double(std::numeric_limits<float>::max()) / (2.0 * std::pow(double(brick), 1.5));
}

// The fixed-rank quantizer (16-bit factors, 8-bit logarithmic core) works relative to the
// largest magnitude: its error floor measured ~5e-5 of it on a smooth field at rank 16, and at
// a range of 1/128 of the magnitude the file already lost ~1 dB PSNR to it (3 dB at 1/300,
// 10 dB at 1/1000). The error-target modes code each brick about its mean and have no floor.
constexpr double kFixedRankSmallestRelativeRange = 1.0 / 128;

}  // namespace

void check_codable(const HistogramRange& range, const std::filesystem::path& file, const CompressParams& params) {
  const double magnitude = std::max(std::abs(range.lo), std::abs(range.hi));
  const double limit = largest_codable_magnitude(params.layout.brick);
  if (magnitude > limit)
    throw Error(fmt::format("{}: samples: the largest magnitude {:g} exceeds {:g}, the most a float Tucker core of "
                            "a {}^3 brick can hold; rescale the data",
                            file.string(), magnitude, limit, params.layout.brick));
  const double span = range.hi - range.lo;
  if (params.codec.target.kind == TargetKind::none && span > 0 && span < kFixedRankSmallestRelativeRange * magnitude)
    throw Error(fmt::format("{}: samples: the values span only {:g} around a magnitude of {:g}; the fixed-rank mode "
                            "quantizes relative to the magnitude and would lose them (error floor ~5e-5 of it): "
                            "use an error target (--psnr, --rmse or --max-error), which codes each brick about its mean",
                            file.string(), span, magnitude));
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

namespace {

// Allowance for everything not proportional to the volume: code and the libraries' static data
// (the format libraries GDCM and HDF5 alone hold 15 and 8 MiB from process start: `strata --help`
// peaks at 27 MiB, 11 MiB without them), per-thread brick scratch, container index entries,
// allocator slack.
constexpr std::uint64_t kBaselineBytes = 64ull << 20;

// One encoding pass: a writer holding every brick (not yet finished) and the level pipelines
// with their measured errors.
struct EncodedLevels {
  std::unique_ptr<store::ContainerWriter> writer;
  std::vector<std::unique_ptr<LevelPipeline>> levels;
};

EncodedLevels encode_levels(io::VolumeSource& source, const std::filesystem::path& out, const CompressParams& params,
                            const OctreeGeometry& geometry, const HistogramRange& range,
                            const std::vector<BrickTarget>& targets, std::uint64_t slab_bytes, CompressReport& report,
                            ProgressSink& progress, const CodecRun& run) {
  EncodedLevels result;
  result.writer = std::make_unique<store::ContainerWriter>(out);
  store::ContainerWriter& writer = *result.writer;
  std::mutex report_mutex;
  ProgressTask bricks_task(progress, "compress", std::uint64_t(geometry.total_bricks()), "bricks");
  BrickSink sink = [&](const store::BrickKey& key, const EncodedBrick& b, float lo, float hi, std::uint64_t hist) {
    writer.add_brick(index_entry(key, b, lo, hi, hist), b.payload);
    {
      std::lock_guard lock(report_mutex);
      count_brick(report, key, b);
    }
    bricks_task.advance(1);
  };

  // Coarsest level first so each level can point at its parent-level pipeline.
  result.levels.resize(std::size_t(geometry.level_count()));
  for (int l = geometry.level_count() - 1; l >= 0; --l) {
    LevelPipeline* next = l + 1 < geometry.level_count() ? result.levels[std::size_t(l + 1)].get() : nullptr;
    const std::optional<BrickTarget> target =
        targets.empty() ? std::nullopt : std::optional<BrickTarget>(targets[std::size_t(l)]);
    result.levels[std::size_t(l)] =
        std::make_unique<LevelPipeline>(geometry, l, params.codec, run, target, range, sink, next);
  }
  io::for_each_slab(source, [&](const Volume& slab, std::int64_t) { push_slab_to_level0(slab, *result.levels[0]); },
                    silent_progress(), "read", slab_bytes);
  result.levels[0]->finish();
  return result;
}

// The calibrated Δ aims at this fraction of the budget (0.2 dB), so that the spectrum's
// approximations rarely cost a second pass; and the passes before the per-brick caps.
constexpr double kCalibrationAim = 0.955;
constexpr int kCalibratedAttempts = 4;
// A pass more than 1 dB under the budget is encoded again with a larger step, at most
// kMaxRaises times (a raise that misses is bisected against the step that held).
constexpr double kRaiseBelow = 0.79;
constexpr int kMaxRaises = 2;

// The level-0 step of a PSNR/RMSE budget, pass by pass. It starts from the spectrum's
// prediction. A pass that misses the budget shrinks Δ by the error's measured growth; after
// kCalibratedAttempts the step becomes 0 (the per-brick caps that cannot miss). The spectrum
// is the block-DCT basis's; where the encoder's HOSVD basis wins (smooth fields) a pass lands
// far under the budget, and a larger Δ spends it, kept only if it holds.
class BudgetStepSearch {
 public:
  BudgetStepSearch(double budget_mse, double first_step) : budget_(budget_mse), step_(first_step) {}

  double step() const { return step_; }

  // After a pass at step() that measured `mse` on level 0: true when that pass is the one to
  // keep, else step() is the next to try.
  bool accept(int attempt, double mse) {
    if (step_ <= 0) return true;  // no budget, or the per-brick caps
    if (mse > budget_) {
      if (holding_ > 0) {
        // A raised step missed: bisect between it and the step that held, or go back to that one.
        missed_ = step_;
        settled_ = raises_ == kMaxRaises;
        step_ = settled_ ? holding_ : std::sqrt(holding_ * missed_);
        raises_ += settled_ ? 0 : 1;
      } else {
        shrink(attempt, mse);
      }
      return false;
    }
    if (settled_ || raises_ == kMaxRaises || !(mse > 0) || mse >= kRaiseBelow * budget_) return true;
    holding_ = step_;
    ++raises_;
    step_ = missed_ > 0 ? std::sqrt(holding_ * missed_) : step_ * std::min(4.0, std::sqrt(kCalibrationAim * budget_ / mse));
    return false;
  }

 private:
  // The error grows as Δ^α, α from the last two passes (1 after the first: near Δ² only at high
  // rates, nearer Δ at low rates where coefficients drop out).
  void shrink(int attempt, double mse) {
    double alpha = 1;
    if (previous_step_ > 0 && previous_step_ != step_ && previous_mse_ > 0)
      alpha = std::clamp(std::log(mse / previous_mse_) / std::log(step_ / previous_step_), 0.5, 2.0);
    previous_step_ = step_;
    previous_mse_ = mse;
    step_ = attempt + 1 < kCalibratedAttempts ? step_ * std::min(0.95, std::pow(kCalibrationAim * budget_ / mse, 1 / alpha))
                                              : 0;
  }

  double budget_, step_;
  double holding_ = 0, missed_ = 0;  // the last step that held, the smallest raised one that missed
  double previous_step_ = 0, previous_mse_ = 0;
  int raises_ = 0;
  bool settled_ = false;  // back at the step that held: keep whatever it gives
};

}  // namespace

std::uint64_t fixed_working_set(const OctreeGeometry& geometry, bool feature_reference) {
  const BrickLayout& l = geometry.layout();
  std::uint64_t bytes = 0;
  for (int level = 0; level < geometry.level_count(); ++level) {
    const Extent& d = geometry.level(level).dims;
    const std::uint64_t slice = std::uint64_t(d.x * d.y) * sizeof(float);
    bytes += slice * std::uint64_t(l.brick + 1 + l.core() + 1);  // window + decoded row + pending pair
    // Reference slices arrive ahead of the samples, by up to a brick row of this level.
    if (feature_reference && level > 0) bytes += 2 * slice * std::uint64_t(l.brick + 1 + l.core() + 1);
  }
  return bytes;
}

std::uint64_t input_slab_bytes(const OctreeGeometry& geometry, const VolumeInfo& source, const CompressParams& params) {
  if (params.memory_limit == 0) return io::kDefaultSlabBytes;
  const std::uint64_t fixed =
      fixed_working_set(geometry, codec_for(params).needs_feature_reference()) + kBaselineBytes;
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

std::vector<int> feature_scale_ladder(int rank) {
  const int step = std::max(1, (rank + 3) / 4);
  std::vector<int> ladder;
  for (int k = step; k < rank; k += step) ladder.push_back(k);
  ladder.push_back(rank);
  return ladder;
}

namespace {

}  // namespace

void RangeScan::widen(const Volume& slab, StepCalibrator* calibrator) {
  visit_dtype(slab.dtype(), [&](auto tag) {
    using T = decltype(tag);
    const auto values = slab.samples<T>();
    if (values.empty()) return;
    // Branch-free min/max in the sample type (vectorised), widened once per slab. NaN and
    // infinite samples are left out: the bricks keep them in a mask (ta/non_finite.hpp).
    if constexpr (std::is_floating_point_v<T>) {
      T mn = std::numeric_limits<T>::infinity(), mx = -mn;
      for (T v : values) {
        const bool finite = std::abs(v) <= std::numeric_limits<T>::max();
        mn = finite && v < mn ? v : mn;
        mx = finite && v > mx ? v : mx;
      }
      if (mn <= mx) {
        lo = std::min(lo, double(mn));
        hi = std::max(hi, double(mx));
      }
    } else {
      T mn = values[0], mx = values[0];
      for (T v : values) {
        mn = v < mn ? v : mn;
        mx = v > mx ? v : mx;
      }
      lo = std::min(lo, double(mn));
      hi = std::max(hi, double(mx));
    }
    const std::size_t slice_size = std::size_t(slab.dims().x * slab.dims().y);
    for (std::int64_t z = 0; calibrator && z < slab.dims().z; ++z) {
      const T* src = values.data() + std::size_t(z) * slice_size;
      calibrator->push_slice(std::vector<float>(src, src + slice_size));
    }
  });
}

store::BrickEntry index_entry(const store::BrickKey& key, const EncodedBrick& b, float lo, float hi,
                              std::uint64_t histogram) {
  store::BrickEntry entry{key, b.kind, 0, 0, 0, lo, hi, histogram};
  if (b.kind == store::PayloadKind::constant) entry.min = entry.max = b.constant_value;
  return entry;
}

void count_brick(CompressReport& report, const store::BrickKey& key, const EncodedBrick& b) {
  LevelCounts& counts = report.levels[key.level];
  ++counts.bricks;
  counts.constant += b.kind == store::PayloadKind::constant;
  counts.hosvd_trials += b.block_dct_bytes > 0;
  report.core_bytes += b.core_bytes;
  report.factor_bytes += b.factor_bytes;
  report.brick_header_bytes += b.header_bytes;
}

int default_rank(const BrickLayout& layout, TargetKind target) {
  return target == TargetKind::none ? layout.brick / 2 : layout.brick;
}

CompressReport compress_volume(io::VolumeSource& source, const std::filesystem::path& out,
                               const CompressParams& requested, ProgressSink& progress) {
  validate(requested);
  const BrickCodec& codec = codec_for(requested);
  const CompressParams params = codec.normalized(requested);
  const auto start = Clock::now();
  const VolumeInfo& info = source.info();
  const OctreeGeometry geometry(info.dims, params.layout);
  CompressReport report;
  report.input_voxels = std::uint64_t(info.dims.voxel_count());

  const std::uint64_t slab_bytes = input_slab_bytes(geometry, info, params);
  const std::unique_ptr<CodecRun> run = codec.begin({source, params, geometry, slab_bytes, progress});
  const ErrorTarget& target = params.codec.target;
  const bool budget = target.kind == TargetKind::psnr || target.kind == TargetKind::rmse;
  std::optional<StepCalibrator> calibrator;
  const int calibration_block = dct_block_width(params.layout.core());
  if (budget) calibrator.emplace(info.dims, calibration_block > 0 ? calibration_block : 8);
  const HistogramRange range = value_range(source, progress, slab_bytes, calibrator ? &*calibrator : nullptr);
  report.prepass_seconds = seconds_since(start);
  check_codable(range, source.path(), params);

  const double budget_mse = budget ? std::pow(target_rmse(target, range.lo, range.hi), 2) : 0;
  if (calibrator) calibrator->finish();
  BudgetStepSearch search(budget_mse,
                          calibrator ? calibrator->step_for_mse(kCalibrationAim * budget_mse, kMseZeroThreshold) : 0);
  for (int attempt = 0;; ++attempt) {
    std::vector<BrickTarget> targets;
    if (target.kind != TargetKind::none)
      targets = level_targets(target, range.lo, range.hi, geometry.level_count(), params.codec.rank,
                              params.codec.zstd_level, search.step());
    report.levels.assign(std::size_t(geometry.level_count()), LevelCounts{});
    report.core_bytes = report.factor_bytes = report.brick_header_bytes = 0;
    EncodedLevels encoded =
        encode_levels(source, out, params, geometry, range, targets, slab_bytes, report, progress, *run);
    // A pass not kept is abandoned here: the writer's temporary goes with it.
    if (!search.accept(attempt, encoded.levels[0]->measured_error().mse())) continue;
    report.attempts = attempt + 1;
    for (std::size_t l = 0; l < encoded.levels.size() && !targets.empty(); ++l) {
      const auto& e = encoded.levels[l]->measured_error();
      report.levels[l].rmse = std::sqrt(e.mse());
      report.levels[l].max_error = e.max_abs;
    }
    nlohmann::json metadata = make_metadata(info, geometry, params, range, targets, report.levels);
    run->finish(*encoded.writer, metadata, report);
    report.file_bytes = encoded.writer->finish(std::move(metadata));
    break;
  }
  report.container_bytes = report.file_bytes - report.core_bytes - report.factor_bytes - report.brick_header_bytes;
  report.seconds = seconds_since(start);
  return report;
}

}  // namespace strata::ta
