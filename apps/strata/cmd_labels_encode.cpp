// `strata labels encode IN -o OUT.strata`: Mixture Graph of a label volume (paper 4).
#include <cstdio>

#include "all_volumes.hpp"
#include "cli_checks.hpp"
#include "commands.hpp"
#include "labels_encode_flags.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"

namespace strata::cli {

namespace {

void run_labels_encode(const LabelsEncodeArgs& args, const GlobalOptions& global) {
  const mixture::EncodeOptions o = to_encode_options(args);
  auto progress = global.make_progress();
  io::ReadOptions read = args.raw.to_read_options();
  read.progress = progress.get();
  std::vector<std::string> inputs{args.input};
  if (const auto table = names_table(args)) inputs.push_back(table->string());
  check_output_file(args.output, "--output", inputs, {io::kStrataExtension});
  const auto encode = [&](io::VolumeSource& source, const std::filesystem::path& output, const std::string& name) {
    mixture::require_label_dtype(args.input, source.info().dtype);
    print_encode_report(name, source.info().dims, o, args, mixture::encode_labels(source, output, o, *progress));
  };
  if (args.all_volumes) {
    encode_all_volumes(args.input, read, args.output, encode);
    return;
  }
  auto source = io::open_volume(args.input, read);
  encode(*source, args.output, args.output);
}

}  // namespace

void register_labels_encode(CLI::App& labels, const GlobalOptions& global) {
  auto args = std::make_shared<LabelsEncodeArgs>();
  CLI::App* cmd = labels.add_subcommand("encode", "Encode a label volume as a Mixture Graph (.strata)");
  add_labels_encode_flags(*cmd, *args);
  add_all_volumes_flag(*cmd, args->all_volumes);
  cmd->callback([args, &global] {
    naming_files({args->input, args->output, args->names}, [&] { run_labels_encode(*args, global); });
  });
}

}  // namespace strata::cli
