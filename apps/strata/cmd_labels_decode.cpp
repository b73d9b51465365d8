// `strata labels decode IN.strata --level L -o OUT [--label ID]`.
#include <algorithm>
#include <memory>
#include <cstdio>
#include <optional>
#include <vector>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/ome_zarr.hpp"
#include "strata/io/precomputed.hpp"
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

// A label level as a precomputed segmentation wants it: uint32 ids (uint64 for 64-bit ones), so
// Neuroglancer shows segments rather than an image.
class SegmentationIds final : public io::VolumeSource {
 public:
  explicit SegmentationIds(io::VolumeSource& level) : level_(level), info_(level.info()) {
    info_.dtype = dtype_size(info_.dtype) == 8 ? DType::u64 : DType::u32;
  }
  const VolumeInfo& info() const override { return info_; }
  const std::filesystem::path& path() const override { return level_.path(); }
  Volume read_box(const Box& box) override {
    Volume v = level_.read_box(box);
    return v.dtype() == info_.dtype ? v : v.converted(info_.dtype);
  }

 private:
  io::VolumeSource& level_;
  VolumeInfo info_;
};

// Every level into one multiscale output (OME-Zarr, Neuroglancer precomputed): level 0 exact,
// the coarser ones the dominant label, as `decompress` writes a scalar file's pyramid.
void write_pyramid(const mixture::EncodedLabels& labels, const std::string& output) {
  std::vector<std::unique_ptr<io::VolumeSource>> owned;
  std::vector<io::VolumeSource*> levels;
  const bool precomputed = io::output_format(output).name == "precomputed";
  for (int l = 0; l < labels.level_count(); ++l) {
    owned.push_back(std::make_unique<mixture::LevelDecoder>(labels, l));
    if (precomputed) owned.push_back(std::make_unique<SegmentationIds>(*owned.back()));
    levels.push_back(owned.back().get());
  }
  if (precomputed)
    io::write_precomputed(output, levels);
  else
    io::write_ome_zarr_pyramid(output, levels);
}

// Decodes slab by slab into the output, so the level is never held whole (the writer streams
// raw, NRRD, NIfTI and TIFF; it writes a temporary file, renamed when complete).
void run_labels_decode(const LabelsDecodeArgs& args, const GlobalOptions& global) {
  check_volume_output(args.output, "--output", {args.input});
  const mixture::EncodedLabels labels(store::open_volume(args.input, args.volume));
  if (args.level < 0 || args.level >= labels.level_count())
    throw Error("--level: " + std::to_string(args.level) + " is not in 0.." + std::to_string(labels.level_count() - 1) +
                " for " + args.input);
  if (args.level == 0 && !args.label && io::output_format(args.output).capabilities.multiscale)
    return write_pyramid(labels, args.output);
  const mixture::LevelDecoder decoder(labels, args.level, args.label);
  const VolumeInfo& info = decoder.info();
  // A slab holds its samples and one u32 node id per voxel, as an encoding slab does.
  const std::int64_t step = mixture::label_slab_slices(info, 0);
  const auto progress = global.make_progress();
  ProgressTask task(*progress, "decode", std::uint64_t(info.dims.voxel_count()), "vox");
  const std::unique_ptr<io::VolumeWriter> writer = io::create_volume_writer(args.output, info);
  for (std::int64_t z0 = 0; z0 < info.dims.z; z0 += step) {
    const Volume slab = decoder.slices(z0, std::min(info.dims.z, z0 + step));
    writer->write_slab(slab);
    task.advance(std::uint64_t(slab.voxel_count()));
  }
  writer->finish();
}

}  // namespace

void register_labels_decode(CLI::App& labels, const GlobalOptions& global) {
  auto args = std::make_shared<LabelsDecodeArgs>();
  CLI::App* cmd = labels.add_subcommand(
      "decode", "Decode a level: level 0 = the original labels (bit-exact); coarser = dominant label per voxel, "
                "or with --label that label's fraction (f32)");
  cmd->add_option("input", args->input, "Input .strata label file")->required();
  cmd->add_option("-o,--output", args->output,
                  "Output volume (.nrrd, .nii, .nii.gz, .raw, .tif, ...); a multiscale format (.ome.zarr, .precomputed) "
                  "receives every level unless --level or --label picks one")
      ->required();
  cmd->add_option("--level", args->level, "Mip level (0 = full resolution)")->capture_default_str();
  cmd->add_option("--label", args->label, "Write the fraction (f32, 0..1) of this label value instead");
  add_volume_option(*cmd, args->volume);
  cmd->callback([args, &global] {
    naming_files({args->input, args->output}, [&] { run_labels_decode(*args, global); });
  });
}

}  // namespace strata::cli
