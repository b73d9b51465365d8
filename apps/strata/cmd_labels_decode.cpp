// `strata labels decode IN.strata --level L -o OUT [--label ID]`.
#include <cstdio>
#include <optional>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::cli {

namespace {

struct LabelsDecodeArgs {
  std::string input, output;
  int level = 0;
  std::optional<std::int64_t> label;
  std::optional<std::int64_t> volume;
};

void run_labels_decode(const LabelsDecodeArgs& args, const GlobalOptions&) {
  check_volume_output(args.output, "--output", {args.input});
  const mixture::EncodedLabels labels(store::open_volume(args.input, args.volume));
  if (args.level < 0 || args.level >= labels.level_count())
    throw Error("--level: " + std::to_string(args.level) + " is not in 0.." + std::to_string(labels.level_count() - 1) +
                " for " + args.input);
  Volume v;
  if (args.label) v = labels.label_fraction(args.level, *args.label);
  else if (args.level == 0) v = labels.decode_level0();
  else v = labels.dominant_labels(args.level);
  io::write_volume(args.output, v);
}

}  // namespace

void register_labels_decode(CLI::App& labels, const GlobalOptions& global) {
  auto args = std::make_shared<LabelsDecodeArgs>();
  CLI::App* cmd = labels.add_subcommand(
      "decode", "Decode a level: level 0 = the original labels (bit-exact); coarser = dominant label per voxel, "
                "or with --label that label's fraction (f32)");
  cmd->add_option("input", args->input, "Input .strata label file")->required();
  cmd->add_option("-o,--output", args->output, "Output volume (.nrrd, .nii, .nii.gz, .raw, .tif)")->required();
  cmd->add_option("--level", args->level, "Mip level (0 = full resolution)")->capture_default_str();
  cmd->add_option("--label", args->label, "Write the fraction (f32, 0..1) of this label value instead");
  add_volume_option(*cmd, args->volume);
  cmd->callback([args, &global] {
    naming_files({args->input, args->output}, [&] { run_labels_decode(*args, global); });
  });
}

}  // namespace strata::cli
