// `strata compress IN -o OUT.strata`: bricked tensor-approximation octree (paper 1).
#include "all_volumes.hpp"
#include "cli_checks.hpp"
#include "commands.hpp"
#include "compress_flags.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/compress.hpp"

namespace strata::cli {

namespace {

void run_compress(const CompressArgs& args, const GlobalOptions& global) {
  const ta::CompressParams params = to_params(args);
  check_output_file(args.output, "--output", {args.input}, {io::kStrataExtension});
  auto progress = global.make_progress();
  io::ReadOptions read = args.raw.to_read_options();
  read.progress = progress.get();
  const auto compress = [&](io::VolumeSource& source, const std::filesystem::path& output, const std::string& name) {
    print_compress_report(name, params, ta::compress_volume(source, output, params, *progress));
  };
  if (args.all_volumes) {
    encode_all_volumes(args.input, read, args.output, compress);
    return;
  }
  auto source = io::open_volume(args.input, read);
  compress(*source, args.output, args.output);
}

}  // namespace

void register_compress(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<CompressArgs>();
  CLI::App* cmd = app.add_subcommand("compress", "Compress a volume into a bricked tensor-approximation octree (.strata)");
  add_compress_flags(*cmd, *args);
  add_all_volumes_flag(*cmd, args->all_volumes);
  cmd->callback([args, &global] { run_compress(*args, global); });
}

}  // namespace strata::cli
