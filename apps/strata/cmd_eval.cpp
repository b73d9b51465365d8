// `strata eval ORIGINAL IN.strata [--rank K] [--json]`: storage cost and reconstruction error.
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/core/metrics.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::cli {

namespace {

struct EvalArgs {
  std::string original, compressed;
  int rank = 0;
  bool json = false;
};

nlohmann::json storage_report(const ta::TaVolume& volume) {
  const auto& c = volume.container();
  std::uint64_t header = 0, core = 0, factors = 0;
  ta::DecodeScratch scratch;
  nlohmann::json levels = nlohmann::json::array();
  std::vector<std::int64_t> bricks(std::size_t(volume.geometry().level_count())), constant(bricks.size());
  for (const auto& e : c.bricks()) {
    ++bricks[e.key.level];
    if (e.kind == store::PayloadKind::constant) {
      ++constant[e.key.level];
      continue;
    }
    // Entropy-coded bricks: attribute the stored bytes to the parts in proportion.
    const auto stored = c.payload(e);
    const auto plain = ta::plain_payload(e.kind, stored, volume.quant_scheme(), scratch, c.path().string());
    const auto parts = ta::payload_parts(plain, volume.quant_scheme(), c.path().string());
    const double ratio = double(stored.size()) / double(plain.size());
    const auto core_part = std::uint64_t(double(parts.core_bytes) * ratio);
    const auto factor_part = std::uint64_t(double(parts.factor_bytes) * ratio);
    core += core_part;
    factors += factor_part;
    header += stored.size() - core_part - factor_part;
  }
  for (std::size_t l = 0; l < bricks.size(); ++l) {
    const auto& g = volume.geometry().level(int(l));
    levels.push_back({{"level", l}, {"dims", {g.dims.x, g.dims.y, g.dims.z}}, {"bricks", bricks[l]}, {"constant", constant[l]}});
  }
  const double voxels = double(volume.source_info().dims.voxel_count());
  const std::uint64_t file = c.file_size();
  const std::uint64_t container = file - header - core - factors;
  return {{"file_bytes", file},
          {"bits_per_voxel", 8.0 * double(file) / voxels},
          {"bits_per_voxel_cores", 8.0 * double(core) / voxels},
          {"bits_per_voxel_factors", 8.0 * double(factors) / voxels},
          {"bits_per_voxel_brick_headers", 8.0 * double(header) / voxels},
          {"bits_per_voxel_container", 8.0 * double(container) / voxels},
          {"levels", levels}};
}

nlohmann::json error_report(const ta::TaVolume& volume, io::VolumeSource& original, int k, double* decode_seconds) {
  const Extent dims = volume.source_info().dims;
  const std::int64_t rows = volume.geometry().layout().core() * 4;  // a few brick rows per slab
  ErrorAccumulator acc;
  *decode_seconds = 0;
  for (std::int64_t z0 = 0; z0 < dims.z; z0 += rows) {
    const std::int64_t z1 = std::min(dims.z, z0 + rows);
    const auto t = std::chrono::steady_clock::now();
    Volume decoded = volume.decode_box(0, {{0, 0, z0}, {dims.x, dims.y, z1}}, k);
    *decode_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    acc.add(original.read_slab(z0, z1), decoded);
  }
  const ErrorMetrics m = acc.result();
  return {{"rank", k},          {"snr_db", m.snr_db}, {"psnr_db", m.psnr_db}, {"nrmse", m.nrmse},
          {"rmse", m.rmse},     {"max_abs_error", m.max_abs_error}};
}

void print_report(const nlohmann::json& r) {
  std::printf("file:            %s (%s)\n", r["file"].get<std::string>().c_str(),
              human_bytes(r["storage"]["file_bytes"].get<std::uint64_t>()).c_str());
  std::printf("bits/voxel:      %.3f  (cores %.3f, factors %.3f, brick headers %.3f, index+metadata %.3f)\n",
              r["storage"]["bits_per_voxel"].get<double>(), r["storage"]["bits_per_voxel_cores"].get<double>(),
              r["storage"]["bits_per_voxel_factors"].get<double>(), r["storage"]["bits_per_voxel_brick_headers"].get<double>(),
              r["storage"]["bits_per_voxel_container"].get<double>());
  const auto& e = r["error"];
  std::printf("level 0, rank %d: SNR %.2f dB  PSNR %.2f dB  NRMSE %.5f  max error %.4g\n", e["rank"].get<int>(),
              e["snr_db"].get<double>(), e["psnr_db"].get<double>(), e["nrmse"].get<double>(), e["max_abs_error"].get<double>());
  for (const auto& l : r["storage"]["levels"])
    std::printf("level %d: %lld x %lld x %lld, %lld bricks (%lld constant)\n", l["level"].get<int>(),
                l["dims"][0].get<long long>(), l["dims"][1].get<long long>(), l["dims"][2].get<long long>(),
                l["bricks"].get<long long>(), l["constant"].get<long long>());
  std::printf("decode:          %.3f s for level 0 (%.1f Mvox/s)\n", r["decode_seconds"].get<double>(),
              r["decode_mvox_per_s"].get<double>());
}

void run_eval(const EvalArgs& args, const GlobalOptions&) {
  ta::TaVolume volume(args.compressed);
  auto original = io::open_volume(args.original);
  if (!(original->info().dims == volume.source_info().dims))
    throw Error(args.original + ": dims " + original->info().dims.to_string() + " differ from the compressed volume's " +
                volume.source_info().dims.to_string());
  const int k = args.rank > 0 ? std::min(args.rank, volume.rank()) : volume.rank();
  double decode_seconds = 0;
  nlohmann::json report{{"file", args.compressed}, {"storage", storage_report(volume)}};
  report["error"] = error_report(volume, *original, k, &decode_seconds);
  report["decode_seconds"] = decode_seconds;
  report["decode_mvox_per_s"] = double(volume.source_info().dims.voxel_count()) / decode_seconds / 1e6;
  if (args.json) std::printf("%s\n", report.dump(2).c_str());
  else print_report(report);
}

}  // namespace

void register_eval(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand("eval", "Bits per voxel and reconstruction error of a .strata file against its original");
  cmd->add_option("original", args->original, "The original volume")->required();
  cmd->add_option("compressed", args->compressed, "The .strata file")->required();
  cmd->add_option("--rank", args->rank, "Reconstruction rank K (default: the stored rank)");
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->callback([args, &global] { run_eval(*args, global); });
}

}  // namespace strata::cli
