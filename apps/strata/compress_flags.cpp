#include "compress_flags.hpp"

#include <cmath>
#include <cstdio>
#include <tuple>

#include <fmt/format.h>

#include "cli_checks.hpp"
#include "strata/core/error.hpp"
#include "strata/ta/target_codec.hpp"

namespace strata::cli {

namespace {

constexpr double kMinRmse = 1e-150;

// The error target the flags ask for, checked here so a bad value names its own flag.
ta::ErrorTarget to_target(const CompressArgs& args) {
  ta::ErrorTarget t;
  t.coarse_growth = args.coarse_growth;
  const char* flag = "";
  if (args.psnr) std::tie(t.kind, t.value, flag) = std::tuple(ta::TargetKind::psnr, *args.psnr, "--psnr");
  if (args.rmse) std::tie(t.kind, t.value, flag) = std::tuple(ta::TargetKind::rmse, *args.rmse, "--rmse");
  if (args.max_error) std::tie(t.kind, t.value, flag) = std::tuple(ta::TargetKind::max_error, *args.max_error, "--max-error");
  try {
    ta::check_target(t);
  } catch (const ParameterError& e) {
    if (e.parameter() == "ErrorTarget::value") throw UsageError(flag, e.problem());
    throw UsageError(e.parameter(), e.problem());
  }
  return t;
}

}  // namespace

ta::CompressParams to_params(const CompressArgs& args) {
  if (!(std::isfinite(args.coarse_growth) && args.coarse_growth >= 1))
    throw UsageError("--coarse-growth", "must be a finite factor >= 1, got " + std::to_string(args.coarse_growth));
  // The encoder works with squared errors: a smaller target underflows to 0.
  if (args.rmse && std::isfinite(*args.rmse) && *args.rmse > 0 && *args.rmse < kMinRmse)
    throw UsageError("--rmse", fmt::format("must be at least {:g} (below, its square is no longer a positive number), got {:g}",
                                           kMinRmse, *args.rmse));
  ta::CompressParams p;
  p.layout = {args.brick, args.overlap};
  p.layout.validate();
  if (args.rank < 0) throw UsageError("--rank", "must be positive, got " + std::to_string(args.rank));
  p.codec.target = to_target(args);
  // With a target the rank is only a cap: each brick keeps the ranks its error needs.
  p.codec.rank = args.rank > 0 ? args.rank : ta::default_rank(p.layout, p.codec.target.kind);
  p.codec.quant = quant::QuantScheme::parse(args.quant);
  p.codec.hooi_iterations = args.hooi;
  p.codec.zstd_level = args.zstd;
  if (!args.memory_limit.empty()) p.memory_limit = parse_byte_size(args.memory_limit, "--memory-limit");
  if (args.codec == "ta-global") {
    if (p.codec.target.kind != ta::TargetKind::none)
      throw UsageError("--codec", "ta-global stores fixed-rank cores; --psnr, --rmse and --max-error need ta-bricked");
    p.kind = ta::CodecKind::global;
  }
  return p;
}

void print_compress_report(const std::string& name, const ta::CompressParams& params, const ta::CompressReport& r) {
  std::int64_t bricks = 0, constant = 0, hosvd_trials = 0;
  for (const auto& l : r.levels) {
    bricks += l.bricks;
    constant += l.constant;
    hosvd_trials += l.hosvd_trials;
  }
  std::printf("%s: %lld bricks in %zu levels (%lld constant), %s, %.3f bits/voxel, %.2f s (%.1f Mvox/s)\n",
              name.c_str(), (long long)bricks, r.levels.size(), (long long)constant,
              human_bytes(r.file_bytes).c_str(), 8.0 * double(r.file_bytes) / double(r.input_voxels), r.seconds,
              double(r.input_voxels) / r.seconds / 1e6);
  if (!r.global_fit.empty())
    std::printf("global bases: fit %.5f after %zu sweep%s (%.2f s)\n", r.global_fit.back(), r.global_fit.size(),
                r.global_fit.size() == 1 ? "" : "s", r.global_seconds);
  if (params.codec.target.kind != ta::TargetKind::none && !r.levels.empty())
  {
    std::printf("level 0: RMSE %.6g, max error %.6g (measured; %d encoding pass%s after a %.2f s pre-pass)\n",
                r.levels[0].rmse, r.levels[0].max_error, r.attempts, r.attempts == 1 ? "" : "es", r.prepass_seconds);
    std::printf("bases: %lld of %lld bricks also tried the HOSVD basis\n", (long long)hosvd_trials,
                (long long)(bricks - constant));
  }
}

void add_compress_flags(CLI::App& cmd_app, CompressArgs& args) {
  CLI::App* cmd = &cmd_app;
  cmd->add_option("input", args.input, "Input volume")->required();
  cmd->add_option("-o,--output", args.output, "Output .strata file")->required();
  cmd->add_option("--brick", args.brick, "Brick width B including overlap")->capture_default_str();
  cmd->add_option("--overlap", args.overlap, "Overlap voxels per side")->capture_default_str();
  cmd->add_option("--rank", args.rank,
                  "Stored Tucker rank R per mode (default B/2); with --psnr/--rmse/--max-error the most a brick keeps "
                  "(default B)");
  auto* quant = cmd->add_option("--quant", args.quant,
                                "Quantization: f32 | u16,b8log+ | u16,b8log | u8,b8lin | u16,b16lin | u16,b12log+ | "
                                "u16,b8mu+ ...")
                    ->capture_default_str();
  auto* hooi = cmd->add_option("--hooi", args.hooi, "HOOI sweeps after HOSVD (0 = HOSVD only; at most 100)")
                   ->capture_default_str()
                   ->check(CLI::Range(0, 100));
  cmd->add_option("--zstd", args.zstd,
                  "Lossless zstd level over each quantized brick (0 = off); with a target, of bricks stored losslessly")
      ->capture_default_str()
      ->check(CLI::Range(0, 19));
  // Error targets: each brick gets the ranks and precision the error needs (docs/format.md).
  auto* psnr = cmd->add_option("--psnr", args.psnr,
                               "Error target: PSNR in dB over the value range, for level 0 as a whole");
  auto* rmse = cmd->add_option("--rmse", args.rmse, "Error target: root mean squared error of level 0 (absolute)");
  auto* max_error = cmd->add_option("--max-error", args.max_error,
                                    "Error target: bound on every sample of level 0 (absolute), guaranteed");
  auto* growth = cmd->add_option("--coarse-growth", args.coarse_growth,
                                 "With a target: level l is coded to growth^l times level 0's error")
                     ->capture_default_str();
  psnr->excludes(rmse)->excludes(max_error)->excludes(quant)->excludes(hooi);
  rmse->excludes(max_error)->excludes(quant)->excludes(hooi);
  max_error->excludes(quant)->excludes(hooi);
  (void)growth;
  cmd->add_option("--codec", args.codec,
                  "ta-bricked: bases per brick (paper 1); ta-global: one set of global bases for the volume, a core per "
                  "brick and a feature-scale table (paper 2; fixed rank, --quant applies to the cores)")
      ->capture_default_str()
      ->check(CLI::IsMember({"ta-bricked", "ta-global"}));
  cmd->add_option("--memory-limit", args.memory_limit,
                  "Bound the working memory, e.g. 512M or 2G (input slabs shrink to fit; default: 64 MiB slabs)");
  args.raw.add_to(*cmd);
}

}  // namespace strata::cli
