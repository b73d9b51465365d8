// `strata convert IN OUT`: between raw, NRRD, NIfTI and TIFF, streamed slab by slab.
#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::cli {

namespace {

struct ConvertArgs {
  std::string input, output;
  bool uncompressed = false;
  RawInputArgs raw;
};

void run_convert(const ConvertArgs& args, const GlobalOptions& global) {
  check_volume_output(args.output, "output", {args.input});
  auto progress = global.make_progress();
  io::ReadOptions read = args.raw.to_read_options();
  read.progress = progress.get();
  auto source = io::open_volume(args.input, read);
  const io::FileFormat target = io::detect_format(args.output);
  if (!io::format_supports(target, source->info().dtype))
    throw Error(args.output + ": " + io::format_name(target) + " cannot store " +
                std::string(dtype_name(source->info().dtype)) + " samples");
  io::WriteOptions write;
  write.compress = !args.uncompressed;
  auto writer = io::create_volume_writer(args.output, source->info(), write);
  io::copy_volume(*source, *writer, *progress);
}

}  // namespace

void register_convert(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<ConvertArgs>();
  CLI::App* cmd = app.add_subcommand("convert", "Convert between raw, NRRD, NIfTI-1 and TIFF (format from the extension)");
  cmd->add_option("input", args->input, "Input volume")->required();
  cmd->add_option("output", args->output, "Output volume (.raw, .nrrd, .nii, .nii.gz, .tif, or a folder for slices)")
      ->required();
  cmd->add_flag("--uncompressed", args->uncompressed, "Write NRRD with raw encoding instead of gzip");
  args->raw.add_to(*cmd);
  cmd->callback([args, &global] { run_convert(*args, global); });
}

}  // namespace strata::cli
