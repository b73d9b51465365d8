// `strata info FILE`: what a volume file holds, computed by streaming it slab by slab.
#include <cstdio>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "report.hpp"
#include "strata/core/statistics.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::cli {

namespace {

struct InfoArgs {
  std::string file;
  bool json = false;
  RawInputArgs raw;
};

nlohmann::json volume_report(const io::VolumeSource& source, const VolumeStatistics& st) {
  const VolumeInfo& info = source.info();
  nlohmann::json j;
  j["file"] = source.path().string();
  j["format"] = io::format_name(io::detect_format(source.path()));
  j["dims"] = {info.dims.x, info.dims.y, info.dims.z};
  j["dtype"] = std::string(dtype_name(info.dtype));
  j["spacing"] = {info.spacing.x, info.spacing.y, info.spacing.z};
  j["voxels"] = st.voxel_count;
  j["bytes"] = info.byte_size();
  j["min"] = st.min;
  j["max"] = st.max;
  j["mean"] = st.mean;
  j["stddev"] = st.stddev;
  j["histogram"] = st.histogram;
  if (st.distinct_values) j["distinct_values"] = *st.distinct_values;
  if (dtype_is_integer(info.dtype)) j["background_fraction"] = st.zero_fraction;
  return j;
}

void print_volume_report(const nlohmann::json& j) {
  std::printf("file:        %s\n", j["file"].get<std::string>().c_str());
  std::printf("format:      %s\n", j["format"].get<std::string>().c_str());
  std::printf("dims:        %lld x %lld x %lld  (%llu voxels, %s)\n", j["dims"][0].get<long long>(),
              j["dims"][1].get<long long>(), j["dims"][2].get<long long>(), j["voxels"].get<unsigned long long>(),
              human_bytes(j["bytes"].get<std::uint64_t>()).c_str());
  std::printf("dtype:       %s\n", j["dtype"].get<std::string>().c_str());
  std::printf("spacing:     %g %g %g\n", j["spacing"][0].get<double>(), j["spacing"][1].get<double>(),
              j["spacing"][2].get<double>());
  std::printf("range:       [%g, %g]\n", j["min"].get<double>(), j["max"].get<double>());
  std::printf("mean:        %g (stddev %g)\n", j["mean"].get<double>(), j["stddev"].get<double>());
  std::printf("histogram:   16 bins over the range:");
  for (auto& c : j["histogram"]) std::printf(" %llu", c.get<unsigned long long>());
  std::printf("\n");
  if (j.contains("distinct_values"))
    std::printf("distinct:    %llu values\n", j["distinct_values"].get<unsigned long long>());
  if (j.contains("background_fraction"))
    std::printf("background:  %.4f of voxels are 0\n", j["background_fraction"].get<double>());
}

void run_info(const InfoArgs& args, const GlobalOptions& global) {
  auto progress = global.make_progress();
  io::ReadOptions options = args.raw.to_read_options();
  options.progress = progress.get();
  auto source = io::open_volume(args.file, options);
  StatisticsAccumulator stats;
  io::for_each_slab(*source, [&](const Volume& slab, std::int64_t) { stats.add(slab); }, *progress, "info");
  nlohmann::json report = volume_report(*source, stats.result());
  if (args.json) std::printf("%s\n", report.dump(2).c_str());
  else print_volume_report(report);
}

}  // namespace

void register_info(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = app.add_subcommand("info", "Show dims, dtype, spacing, value range, histogram and label statistics");
  cmd->add_option("file", args->file, "Volume file (raw, .nrrd/.nhdr, .nii/.nii.gz, .tif or a folder of slices)")
      ->required();
  cmd->add_flag("--json", args->json, "Print the report as JSON");
  args->raw.add_to(*cmd);
  cmd->callback([args, &global] { run_info(*args, global); });
}

}  // namespace strata::cli
