// `strata generate KIND --size X[,Y,Z] [--seed S] [--count N] -o OUT`: synthetic volumes of
// any size, streamed to disk.
#include "cli_checks.hpp"
#include "commands.hpp"
#include "strata/core/extent.hpp"
#include "strata/gen/generators.hpp"

namespace strata::cli {

namespace {

struct GenerateArgs {
  std::string kind, size = "128", output, dtype;
  std::uint64_t seed = 1;
  std::int64_t count = 0;
};

void run_generate(const GenerateArgs& args, const GlobalOptions& global) {
  gen::Params params;
  params.kind = gen::parse_kind(args.kind);
  params.dims = parse_extent(args.size);
  params.seed = args.seed;
  params.count = args.count;
  if (!args.dtype.empty()) params.output_dtype = parse_dtype(args.dtype, "--dtype");
  // Sizes, counts and the output are refused before any work (the generator's limits: --help).
  as_usage_error([&] { gen::validate(params); });
  const DType dtype = params.output_dtype.value_or(gen::native_dtype(params.kind));
  check_volume_output(args.output, "--output", {}, &dtype);
  auto progress = global.make_progress();
  gen::generate_to_file(params, args.output, *progress);
}

}  // namespace

void register_generate(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<GenerateArgs>();
  CLI::App* cmd = app.add_subcommand("generate", "Generate a synthetic volume (deterministic for a seed)");
  cmd->add_option("kind", args->kind, "prisms | marschner-lobb | sphere | voronoi | fibres | superpixels")->required();
  cmd->add_option("--size", args->size,
                  "X or X,Y,Z voxels: any depth Z (streamed); one X*Y slice may hold at most 256 MiB of samples, and "
                  "prisms, fibres and voronoi at most 2 GiB of objects placed up front")
      ->capture_default_str();
  cmd->add_option("--seed", args->seed, "Random seed")->capture_default_str()->check(non_negative_integer<std::uint64_t>());
  cmd->add_option("--count", args->count, "Number of blobs / cells / fibres / superpixels per section (0 = the kind's default; at most the "
                  "voxels, of a section for superpixels)")
      ->check(non_negative_integer<std::int64_t>());
  cmd->add_option("--dtype", args->dtype, "Sample type of the output (default: the kind's own, e.g. u16 for prisms)");
  cmd->add_option("-o,--output", args->output, "Output volume file")->required();
  cmd->callback([args, &global] { run_generate(*args, global); });
}

}  // namespace strata::cli
