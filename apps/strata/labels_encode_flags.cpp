#include "labels_encode_flags.hpp"

#include <cstdio>

#include "cli_checks.hpp"

namespace strata::cli {

void add_labels_encode_flags(CLI::App& cmd, LabelsEncodeArgs& args) {
  cmd.add_option("input", args.input, "Input label volume (integer samples)")->required();
  cmd.add_option("-o,--output", args.output, "Output .strata file")->required();
  cmd.add_option("--bits", args.bits,
                 "Quantization bits of the interpolation weights (1.." + std::to_string(mixture::kMaxWeightBits) + ")")
      ->capture_default_str();
  cmd.add_option("--strategy", args.strategy, "Greedy pair choice: max-reduction | max-occurrence | reuse")
      ->capture_default_str()
      ->check(CLI::IsMember({"max-reduction", "max-occurrence", "reuse"}));
  cmd.add_option("--tau", args.tau, "Two-stage threshold (mixtures with more ids vote first; <= 1: one stage)")
      ->capture_default_str();
  cmd.add_option("--normals-band", args.normals_band,
                  "Voxels within this distance of a boundary get their own normal (0..radius)")
      ->capture_default_str();
  cmd.add_option("--normals-diffusion", args.normals_diffusion,
                  "Sweeps carrying the boundary normals into segment interiors (0..64; 0 = boundaries only)")
      ->capture_default_str();
  cmd.add_option("--normals-dither", args.normals_dither,
                  "3D error diffusion when quantizing the normals to 9 bits: on | off (off: banding, smaller graph)")
      ->capture_default_str();
  cmd.add_option("--ids", args.ids, "Per-level id storage: blocks (8^3 block palettes) | fixed (paper Table 1 A)")
      ->capture_default_str()
      ->check(CLI::IsMember({"blocks", "fixed"}));
  cmd.add_option("--zstd", args.zstd,
                 "zstd level over each level's id section (0 = off, at most " +
                     std::to_string(mixture::kMaxIdsZstdLevel) + "; decoded once at open)")
      ->capture_default_str();
  cmd.add_flag("--no-error", args.no_error, "Skip measuring the max l1 reconstruction error");
  cmd.add_flag("--normals", args.normals,
                "Also store a normals graph for smooth, pre-filtered shading (`render --lighting normals`)");
  cmd.add_option("--normals-radius", args.normals_radius,
                  "Half-width in voxels of the window the normals are estimated from (1..4; larger is smoother)")
      ->capture_default_str();
  cmd.add_option("--memory-limit", args.memory_limit,
                  "Bound on the streamed stages' memory, e.g. 4G: the coarser mip levels' ids plus input slabs, "
                  "which shrink to fit (the table of distinct mixtures and the factorisation come on top)");
  cmd.add_option("--names", args.names,
                  "Table of segment names to store in the file (JSON {\"label\": \"name\"}, CSV label,name, or text "
                  "lines 'label name ...'); default: MRIcron's <input>.txt beside the input (aal.nii.gz: aal.nii.txt) "
                  "when there is one; none: store no names");
  cmd.add_flag("--json", args.json, "Print the report as JSON");
  args.raw.add_to(cmd);
}

std::optional<std::filesystem::path> names_table(const LabelsEncodeArgs& args) {
  if (args.names == "none") return std::nullopt;
  if (!args.names.empty()) return std::filesystem::path(args.names);
  return mixture::sidecar_label_names(args.input);
}

mixture::EncodeOptions to_encode_options(const LabelsEncodeArgs& args) {
  mixture::EncodeOptions o;
  o.bits = args.bits;
  o.strategy = mixture::parse_pair_score(args.strategy);
  o.tau = args.tau;
  o.ids = mixture::parse_ids_mode(args.ids);
  o.measure_error = !args.no_error;
  o.ids_zstd = args.zstd;
  o.normals = args.normals;
  o.normal_options.radius = args.normals_radius;
  o.normal_options.diffusion = args.normals_diffusion;
  o.normal_options.band = args.normals_band;
  if (args.normals_dither != "on" && args.normals_dither != "off")
    throw UsageError("--normals-dither", "expected on or off, got '" + args.normals_dither + "'");
  o.normal_options.error_diffusion = args.normals_dither == "on";
  if (!args.memory_limit.empty()) o.memory_limit = parse_byte_size(args.memory_limit, "--memory-limit");
  if (const auto table = names_table(args)) o.names = mixture::load_label_names(*table);
  as_usage_error([&] { mixture::validate(o); });
  return o;
}

nlohmann::json encode_report_json(const std::string& name, const Extent& dims, const mixture::EncodeOptions& o,
                                  const LabelsEncodeArgs& args, const mixture::EncodeReport& r) {
  nlohmann::json j{{"file", name},        {"nodes", r.nodes},
                   {"internal_nodes", r.internal_nodes}, {"sources", r.sources},
                   {"depth", r.depth},           {"distinct_mixtures", r.distinct_mixtures},
                   {"input_pairs", r.input_pairs}, {"file_bytes", r.file_bytes},
                   {"mip_levels", r.mip_levels}, {"mip_voxels", r.mip_voxels},
                   {"nnz_per_voxel", r.nnz_per_voxel}, {"raw_histogram_bytes", r.raw_histogram_bytes},
                   {"background_fraction", r.background_fraction}, {"level0_voxels", r.level0_voxels},
                   {"dims", {dims.x, dims.y, dims.z}},
                   {"bits", o.bits}, {"strategy", args.strategy}, {"tau", o.tau}, {"ids", args.ids},
                   {"graph_bytes", r.graph_bytes}, {"ids_bytes", r.ids_bytes},
                   {"bits_per_voxel", r.bits_per_voxel}, {"seconds", r.seconds},
                   {"factor_seconds", r.factor_seconds}};
  if (r.max_l1) j["max_l1_error"] = *r.max_l1;
  if (o.normals) j["normals"] = {{"bytes", r.normals_bytes}, {"seconds", r.normals_seconds}};
  j["label_names"] = r.names;
  return j;
}

void print_encode_report(const std::string& name, const Extent& dims, const mixture::EncodeOptions& o,
                         const LabelsEncodeArgs& args, const mixture::EncodeReport& r) {
  if (args.json) {
    std::printf("%s\n", encode_report_json(name, dims, o, args, r).dump(2).c_str());
    return;
  }
  std::printf("%s: %llu nodes (%llu sources), depth %u, %s (graph %s), %.3f bits/voxel", name.c_str(),
              (unsigned long long)r.nodes, (unsigned long long)r.sources, r.depth, human_bytes(r.file_bytes).c_str(),
              human_bytes(r.graph_bytes).c_str(), r.bits_per_voxel);
  if (r.max_l1) std::printf(", max l1 error %.5f", *r.max_l1);
  std::printf(", %.2f s (factorize %.2f s)\n", r.seconds, r.factor_seconds);
  if (const auto table = names_table(args); table && !o.names.empty())
    std::printf("names: %zu segment names from %s (%zu of its %zu labels occur)\n", r.names, table->string().c_str(),
                r.names, o.names.size());
  if (o.normals)
    std::printf("normals graph: %s (%.3f bits/voxel), %.2f s\n", human_bytes(r.normals_bytes).c_str(),
                8.0 * double(r.normals_bytes) / double(std::max<std::uint64_t>(1, r.level0_voxels)), r.normals_seconds);
}

}  // namespace strata::cli
