// `strata decompress IN.strata -o OUT [--level L] [--rank K] [--box ...]`.
#include <memory>
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
#include "strata/store/volume_set.hpp"
#include "strata/ta/level_source.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::cli {

namespace {

struct DecompressArgs {
  std::string input, output, box;
  int level = 0, rank = 0;
  bool keep_float = false;
  std::optional<std::int64_t> volume;
};

// Back to the source's sample type (rounded and clamped) unless --float is given or the level
// is coarser than 0 (averages are not source samples).
Volume to_output_type(Volume decoded, const ta::TaVolume& volume, const DecompressArgs& args) {
  if (args.keep_float || args.level > 0 || volume.source_info().dtype == DType::f32) return decoded;
  return decoded.converted(volume.source_info().dtype);
}

// Multiscale outputs (OME-Zarr, Neuroglancer precomputed) take every level of the file, each in
// the source's sample type (or float32 with --float), so viewers get the whole pyramid.
bool writes_pyramid(const DecompressArgs& args) {
  if (args.level != 0 || !args.box.empty()) return false;
  return io::output_format(args.output).capabilities.multiscale;
}

void write_pyramid(const ta::TaVolume& volume, int rank, const DecompressArgs& args) {
  const DType dtype = args.keep_float ? DType::f32 : volume.source_info().dtype;
  std::vector<std::unique_ptr<ta::LevelSource>> levels;
  std::vector<io::VolumeSource*> sources;
  for (int l = 0; l < volume.geometry().level_count(); ++l) {
    levels.push_back(std::make_unique<ta::LevelSource>(volume, l, rank, dtype, args.input));
    sources.push_back(levels.back().get());
  }
  if (io::output_format(args.output).name == "precomputed")
    io::write_precomputed(args.output, sources);
  else
    io::write_ome_zarr_pyramid(args.output, sources);
}

void run_decompress(const DecompressArgs& args, const GlobalOptions&) {
  check_volume_output(args.output, "--output", {args.input});
  ta::TaVolume volume(store::open_volume(args.input, args.volume));
  volume.check_level(args.level);
  const Extent dims = volume.geometry().level(args.level).dims;
  const Box box = args.box.empty() ? Box::whole(dims) : parse_box(args.box);
  const int k = check_rank_flag(args.rank, volume.rank(), args.input);
  if (writes_pyramid(args)) return write_pyramid(volume, k, args);
  Volume decoded = to_output_type(volume.decode_box(args.level, box, k), volume, args);
  decoded.set_geometry(volume.level_geometry(args.level, box));
  io::write_volume(args.output, decoded);
}

}  // namespace

void register_decompress(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<DecompressArgs>();
  CLI::App* cmd = app.add_subcommand("decompress", "Decode a .strata file (any level, rank and box) to a volume file");
  cmd->add_option("input", args->input, "Input .strata file")->required();
  cmd->add_option("-o,--output", args->output,
                  "Output volume (.nrrd, .nii, .nii.gz, .raw, .tif, ...); a multiscale format (.ome.zarr, "
                  ".precomputed) receives every level unless --level or --box picks one")
      ->required();
  cmd->add_option("--level", args->level, "Octree level (0 = full resolution)")->capture_default_str();
  cmd->add_option("--rank", args->rank, "Reconstruction rank K, 1..the stored rank (default: the stored rank)");
  cmd->add_option("--box", args->box, "Sub-box x0,y0,z0:x1,y1,z1 in level coordinates (half-open)");
  cmd->add_flag("--float", args->keep_float, "Write f32 samples instead of the source type");
  add_volume_option(*cmd, args->volume);
  cmd->callback([args, &global] { run_decompress(*args, global); });
}

}  // namespace strata::cli
