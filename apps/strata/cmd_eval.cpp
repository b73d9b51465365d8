// `strata eval ORIGINAL IN.strata [--rank K] [--json]`: storage cost and reconstruction error.
#include <optional>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/evaluate.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::cli {

namespace {

struct EvalArgs {
  std::string original, compressed;
  std::optional<std::int64_t> volume;
  int rank = 0;
  bool json = false;
};

nlohmann::json eval_json(const ta::TaVolume& volume, const ta::StorageReport& s, const ta::ErrorReport& e) {
  const VolumeInfo& src = volume.source_info();
  nlohmann::json levels = nlohmann::json::array();
  for (std::size_t l = 0; l < s.bricks_per_level.size(); ++l) {
    const auto& g = volume.geometry().level(int(l));
    levels.push_back({{"level", l},
                      {"dims", {g.dims.x, g.dims.y, g.dims.z}},
                      {"bricks", s.bricks_per_level[l]},
                      {"constant", s.constant_per_level[l]},
                      {"payload_bytes", s.payload_bytes_per_level[l]},
                      {"bits_per_voxel", s.bits_per_voxel(s.payload_bytes_per_level[l], src)}});
    if (l > 0 && l - 1 < e.coarse.size()) {
      const ErrorMetrics& c = e.coarse[l - 1];
      levels.back()["error_vs_box_filtered"] = {{"snr_db", c.snr_db}, {"psnr_db", c.psnr_db}, {"rmse", c.rmse},
                                                {"max_abs_error", c.max_abs_error}};
    }
  }
  const ErrorMetrics& m = e.metrics;
  return {{"file", volume.container().name()},
          {"storage",
           {{"file_bytes", s.file_bytes},
            {"bits_per_voxel", s.bits_per_voxel(s.file_bytes, src)},
            {"bits_per_voxel_cores", s.bits_per_voxel(s.core_bytes, src)},
            {"bits_per_voxel_factors", s.bits_per_voxel(s.factor_bytes, src)},
            {"bits_per_voxel_brick_headers", s.bits_per_voxel(s.brick_header_bytes, src)},
            {"bits_per_voxel_corrections", s.bits_per_voxel(s.correction_bytes, src)},
            {"bits_per_voxel_lossless_bricks", s.bits_per_voxel(s.lossless_bytes, src)},
            {"bits_per_voxel_non_finite_masks", s.bits_per_voxel(s.mask_bytes, src)},
            {"bits_per_voxel_container", s.bits_per_voxel(s.container_bytes, src)},
            {"bits_per_voxel_feature_scale", s.bits_per_voxel(s.feature_scale_bytes, src)},
            {"levels", levels}}},
          {"error",
           {{"rank", e.rank}, {"snr_db", m.snr_db}, {"psnr_db", m.psnr_db}, {"nrmse", m.nrmse}, {"rmse", m.rmse},
            {"max_abs_error", m.max_abs_error}}},
          {"decode_seconds", e.decode_seconds},
          {"decode_mvox_per_s", double(src.dims.voxel_count()) / e.decode_seconds / 1e6}};
}

void print_report(const nlohmann::json& r) {
  const auto& s = r["storage"];
  std::printf("file:            %s (%s)\n", r["file"].get<std::string>().c_str(),
              human_bytes(s["file_bytes"].get<std::uint64_t>()).c_str());
  std::printf("bits/voxel:      %.3f  (cores %.3f, factors %.3f, brick headers %.3f, index+metadata %.3f)\n",
              s["bits_per_voxel"].get<double>(), s["bits_per_voxel_cores"].get<double>(),
              s["bits_per_voxel_factors"].get<double>(), s["bits_per_voxel_brick_headers"].get<double>(),
              s["bits_per_voxel_container"].get<double>());
  if (s["bits_per_voxel_feature_scale"].get<double>() > 0)
    std::printf("                 (global bases counted as factors; feature-scale table %.3f)\n",
                s["bits_per_voxel_feature_scale"].get<double>());
  if (s["bits_per_voxel_corrections"].get<double>() > 0 || s["bits_per_voxel_lossless_bricks"].get<double>() > 0)
    std::printf("                 (max-error corrections %.3f, lossless bricks %.3f)\n",
                s["bits_per_voxel_corrections"].get<double>(), s["bits_per_voxel_lossless_bricks"].get<double>());
  if (s["bits_per_voxel_non_finite_masks"].get<double>() > 0)
    std::printf("                 (NaN and infinity masks %.3f)\n", s["bits_per_voxel_non_finite_masks"].get<double>());
  const auto& e = r["error"];
  std::printf("level 0, rank %d: SNR %.2f dB  PSNR %.2f dB  NRMSE %.5f  max error %.4g\n", e["rank"].get<int>(),
              e["snr_db"].get<double>(), e["psnr_db"].get<double>(), e["nrmse"].get<double>(),
              e["max_abs_error"].get<double>());
  for (const auto& l : s["levels"]) {
    std::printf("level %d: %lld x %lld x %lld, %lld bricks (%lld constant)", l["level"].get<int>(),
                l["dims"][0].get<long long>(), l["dims"][1].get<long long>(), l["dims"][2].get<long long>(),
                l["bricks"].get<long long>(), l["constant"].get<long long>());
    if (l.contains("error_vs_box_filtered"))
      std::printf(", SNR %.2f dB against the box-filtered original", l["error_vs_box_filtered"]["snr_db"].get<double>());
    std::printf("\n");
  }
  std::printf("decode:          %.3f s for level 0 (%.1f Mvox/s)\n", r["decode_seconds"].get<double>(),
              r["decode_mvox_per_s"].get<double>());
}

void run_eval(const EvalArgs& args, const GlobalOptions&) {
  // --volume picks the same volume of both: a time point of a series and its member of the set.
  ta::TaVolume volume(store::open_volume(args.compressed, args.volume));
  const int k = check_rank_flag(args.rank, volume.rank(), args.compressed);
  io::ReadOptions read;
  read.volume = args.volume;
  auto original = io::open_volume(args.original, read);
  nlohmann::json report = eval_json(volume, ta::storage_report(volume), ta::error_report(volume, *original, k, true));
  const io::ByteSource& source = volume.container().source();
  if (source.remote()) report["transfer"] = transfer_json(source.transfer_stats());
  if (args.json) std::printf("%s\n", report.dump(2).c_str());
  else print_report(report);
  if (!args.json && report.contains("transfer")) print_transfer(report["transfer"]);
}

}  // namespace

void register_eval(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd =
      app.add_subcommand("eval", "Bits per voxel and reconstruction error of a .strata file against its original");
  cmd->add_option("original", args->original, "The original volume")->required();
  cmd->add_option("compressed", args->compressed, "The .strata file")->required();
  cmd->add_option("--rank", args->rank, "Reconstruction rank K, 1..the stored rank (default: the stored rank)");
  cmd->add_flag("--json", args->json, "Print JSON");
  add_volume_option(*cmd, args->volume);
  cmd->callback([args, &global] { run_eval(*args, global); });
}

}  // namespace strata::cli
