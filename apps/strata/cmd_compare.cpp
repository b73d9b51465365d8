// `strata compare A B`: SNR, PSNR, NRMSE and max error of B against the original A, over the
// voxels finite in both, and how many NaN or infinite voxels match or do not.
#include <cstdio>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "strata/core/error.hpp"
#include "strata/core/metrics.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::cli {

namespace {

struct CompareArgs {
  std::string original, approximation;
  bool json = false;
};

nlohmann::json metrics_json(const ErrorMetrics& m) {
  auto finite_or_string = [](double v) -> nlohmann::json {
    if (std::isfinite(v)) return v;
    return v > 0 ? "inf" : "-inf";
  };
  return {{"voxels", m.voxel_count},         {"snr_db", finite_or_string(m.snr_db)},
          {"psnr_db", finite_or_string(m.psnr_db)}, {"nrmse", m.nrmse},
          {"rmse", m.rmse},                        {"max_abs_error", m.max_abs_error},
          {"signal_rms", m.signal_rms},            {"value_min", m.value_min},
          {"value_max", m.value_max},              {"masked_matched", m.masked_matched},
          {"masked_mismatched", m.masked_mismatched}};
}

void run_compare(const CompareArgs& args, const GlobalOptions& global) {
  auto progress = global.make_progress();
  io::ReadOptions read;
  read.progress = progress.get();
  auto a = io::open_volume(args.original, read);
  auto b = io::open_volume(args.approximation, read);
  if (!(a->info().dims == b->info().dims))
    throw Error(args.approximation + ": dims " + b->info().dims.to_string() + " differ from " + args.original +
                " (" + a->info().dims.to_string() + ")");
  ErrorAccumulator acc;
  io::for_each_slab(*a, [&](const Volume& slab, std::int64_t z0) { acc.add(slab, b->read_slab(z0, z0 + slab.dims().z)); },
                    *progress, "compare");
  ErrorMetrics m = acc.result();
  if (args.json) {
    std::printf("%s\n", metrics_json(m).dump(2).c_str());
    return;
  }
  std::printf("voxels:     %llu\n", (unsigned long long)m.voxel_count);
  if (m.masked_matched + m.masked_mismatched > 0)
    std::printf("non-finite: %llu voxels NaN or infinite in both alike, %llu in one only or unlike (left out below)\n",
                (unsigned long long)m.masked_matched, (unsigned long long)m.masked_mismatched);
  std::printf("SNR:        %.3f dB\n", m.snr_db);
  std::printf("PSNR:       %.3f dB (range %g..%g)\n", m.psnr_db, m.value_min, m.value_max);
  std::printf("NRMSE:      %.6g\n", m.nrmse);
  std::printf("RMSE:       %.6g\n", m.rmse);
  std::printf("max error:  %.6g\n", m.max_abs_error);
}

}  // namespace

void register_compare(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand("compare", "Error metrics of an approximation B against the original A");
  cmd->add_option("original", args->original, "Original volume A")->required();
  cmd->add_option("approximation", args->approximation, "Approximation B (same dims)")->required();
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->callback([args, &global] { run_compare(*args, global); });
}

}  // namespace strata::cli
