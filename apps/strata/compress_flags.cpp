#include "compress_flags.hpp"

#include <cstdio>
#include <tuple>

#include <fmt/format.h>

#include "cli_checks.hpp"
#include "strata/core/error.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/target_codec.hpp"

namespace strata::cli {

namespace {

// The one error target the three target flags may ask for, and the flag that set it.
std::pair<ta::ErrorTarget, const char*> to_target(const CompressArgs& args) {
  ta::ErrorTarget t;
  t.coarse_growth = args.coarse_growth;
  const char* flag = "";
  if (args.psnr) std::tie(t.kind, t.value, flag) = std::tuple(ta::TargetKind::psnr, *args.psnr, "--psnr");
  if (args.rmse) std::tie(t.kind, t.value, flag) = std::tuple(ta::TargetKind::rmse, *args.rmse, "--rmse");
  if (args.max_error) std::tie(t.kind, t.value, flag) = std::tuple(ta::TargetKind::max_error, *args.max_error, "--max-error");
  return {t, flag};
}

// "--codec" help: every registered codec and what it stores.
std::string codec_help() {
  std::string help;
  for (const std::string& name : ta::codec_names()) {
    help += (help.empty() ? "" : "; ") + name + ":";
    for (const ta::BrickCodec* c : ta::codecs())
      if (c->name() == name) help += " " + std::string(c->summary()) + " (" + std::string(ta::codec_mode_name(c->mode())) + ")";
  }
  return help;
}

}  // namespace

// Maps the flags to parameters; the library's validate() holds every rule, and its
// ParameterError is reported against the flag that set the value.
ta::CompressParams to_params(const CompressArgs& args) {
  ta::CompressParams p;
  p.layout = {args.brick, args.overlap};
  const auto [target, target_flag] = to_target(args);
  p.codec.target = target;
  // With a target the rank is only a cap: each brick keeps the ranks its error needs.
  p.codec.rank = args.rank != 0 ? args.rank : ta::default_rank(p.layout, p.codec.target.kind);
  if (!args.quant.empty()) p.codec.quant = quant::QuantScheme::parse(args.quant);
  p.codec.hooi_iterations = args.hooi;
  p.codec.zstd_level = args.zstd;
  p.codec_name = args.codec;
  if (!args.memory_limit.empty()) p.memory_limit = parse_byte_size(args.memory_limit, "--memory-limit");
  try {
    ta::validate(p);
  } catch (const ParameterError& e) {
    // Exit codes as they always were: the layout and the rank exit 1 (a runtime error naming
    // the flag, see cli_message); the target, the codec and the ranges of --hooi and --zstd are
    // usage errors (exit 2).
    const std::string& field = e.parameter();
    if (field.starts_with("BrickLayout::") || field == "CodecParams::rank") throw;
    throw UsageError(field == "ErrorTarget::value" ? target_flag : flag_for_parameter(field), e.problem());
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
  cmd->add_option("--quant", args.quant,
                  "Quantization: f32 | u16,b8log+ | u16,b8log | u8,b8lin | u16,b16lin | u16,b12log+ | u16,b8mu+ ... "
                  "(default u16,b8log+; an error target chooses its own)");
  cmd->add_option("--hooi", args.hooi,
                  "HOOI sweeps after HOSVD (0 = HOSVD only; at most " + std::to_string(ta::kMaxHooiIterations) + ")")
      ->capture_default_str();
  cmd->add_option("--zstd", args.zstd,
                  "Lossless zstd level over each quantized brick (0 = off, at most " +
                      std::to_string(ta::kMaxZstdLevel) + "); with a target, of bricks stored losslessly")
      ->capture_default_str();
  // Error targets: each brick gets the ranks and precision the error needs (docs/format.md).
  auto* psnr = cmd->add_option("--psnr", args.psnr,
                               "Error target: PSNR in dB over the value range, for level 0 as a whole");
  auto* rmse = cmd->add_option("--rmse", args.rmse, "Error target: root mean squared error of level 0 (absolute)");
  auto* max_error = cmd->add_option("--max-error", args.max_error,
                                    "Error target: bound on every sample of level 0 (absolute), guaranteed");
  cmd->add_option("--coarse-growth", args.coarse_growth,
                  "With a target: level l is coded to growth^l times level 0's error")
      ->capture_default_str();
  psnr->excludes(rmse)->excludes(max_error);
  rmse->excludes(max_error);
  cmd->add_option("--codec", args.codec, codec_help())->capture_default_str();
  cmd->add_option("--memory-limit", args.memory_limit,
                  "Bound the working memory, e.g. 512M or 2G (input slabs shrink to fit; default: 64 MiB slabs)");
  args.raw.add_to(*cmd);
}

}  // namespace strata::cli
