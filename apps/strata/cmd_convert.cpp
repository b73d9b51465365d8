// `strata convert IN OUT`: between the registered volume formats (raw, NRRD, NIfTI, TIFF, ...),
// streamed slab by slab by io::convert_volume.
#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/io/convert.hpp"
#include "strata/io/formats.hpp"

namespace strata::cli {

namespace {

struct ConvertArgs {
  std::string input, output;
  bool uncompressed = false;
  RawInputArgs raw;
};

void run_convert(const ConvertArgs& args, const GlobalOptions& global) {
  io::WriteOptions write;
  write.compress = !args.uncompressed;
  check_volume_output(args.output, "output", {args.input}, nullptr, write);
  auto progress = global.make_progress();
  io::convert_volume(args.input, args.output, args.raw.to_read_options(), write, *progress);
}

// "raw (.raw, .bin), nrrd (.nrrd, .nhdr), ...": the registered formats for --help.
std::string formats_help() {
  std::string text;
  for (const io::VolumeFormat* f : io::formats()) {
    std::string names;
    for (const std::string& ext : f->extensions) names += (names.empty() ? "" : ", ") + ext;
    if (!f->directory.empty()) names += (names.empty() ? "" : " or ") + f->directory;
    text += (text.empty() ? "" : "; ") + f->name + " (" + names + ")";
  }
  return text;
}

}  // namespace

void register_convert(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<ConvertArgs>();
  CLI::App* cmd = app.add_subcommand(
      "convert", "Convert between " + io::format_titles_text("and") + " (format from the extension)");
  cmd->add_option("input", args->input, "Input volume (format from the extension, else from its first bytes)")
      ->required();
  cmd->add_option("output", args->output, "Output volume; its extension chooses the format: " + formats_help())
      ->required();
  cmd->add_flag("--uncompressed", args->uncompressed, "Write NRRD with raw encoding instead of gzip");
  args->raw.add_to(*cmd);
  cmd->footer("Formats and what each can store: strata formats");
  cmd->callback([args, &global] { run_convert(*args, global); });
}

}  // namespace strata::cli
