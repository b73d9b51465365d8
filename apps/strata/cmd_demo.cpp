// `strata demo`: the main job on the embedded sample data. Generates a scalar and a label
// volume, converts between formats, reports statistics and error metrics, and writes
// everything to demo-out/ (report.json holds the figures).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/core/metrics.hpp"
#include "strata/core/statistics.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/box_query.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/image.hpp"
#include "strata/render/render_session.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/evaluate.hpp"

namespace strata::cli {

namespace {

namespace fs = std::filesystem;

struct DemoArgs {
  std::string output_dir = "demo-out";
  std::int64_t size = 128;
};

nlohmann::json stats_json(const std::string& name, const Volume& v) {
  VolumeStatistics s = compute_statistics(v);
  nlohmann::json j{{"name", name},
                   {"dims", {v.dims().x, v.dims().y, v.dims().z}},
                   {"dtype", std::string(dtype_name(v.dtype()))},
                   {"min", s.min},
                   {"max", s.max},
                   {"mean", s.mean}};
  if (s.distinct_values) j["distinct_values"] = *s.distinct_values;
  if (dtype_is_integer(v.dtype())) j["background_fraction"] = s.zero_fraction;
  std::printf("  %-22s %5lldx%lldx%lld %-4s range [%g, %g] mean %.2f", name.c_str(), (long long)v.dims().x,
              (long long)v.dims().y, (long long)v.dims().z, std::string(dtype_name(v.dtype())).c_str(), s.min, s.max,
              s.mean);
  if (s.distinct_values && *s.distinct_values < 100000)
    std::printf("  %llu distinct values, %.1f%% zeros", (unsigned long long)*s.distinct_values, 100 * s.zero_fraction);
  std::printf("\n");
  return j;
}

// Requantizes to 8 bits over the value range and back: the simplest lossy baseline, so the
// metrics line shows what a naive 8 bit/voxel representation costs.
Volume requantize_8bit(const Volume& v) {
  VolumeStatistics s = compute_statistics(v);
  Volume out(v.dims(), DType::f32, v.spacing());
  const double range = s.max > s.min ? s.max - s.min : 1.0;
  Volume as_double = v.converted(DType::f64);
  auto src = as_double.samples<double>();
  auto dst = out.samples<float>();
  for (std::size_t i = 0; i < src.size(); ++i) {
    double code = std::nearbyint((src[i] - s.min) / range * 255.0);
    dst[i] = float(s.min + code / 255.0 * range);
  }
  return out;
}

nlohmann::json metrics_line(const std::string& what, const ErrorMetrics& m, double bits) {
  std::printf("  %-34s SNR %6.2f dB  PSNR %6.2f dB  NRMSE %.5f  max %.4g  %.2f bits/voxel\n", what.c_str(), m.snr_db,
              m.psnr_db, m.nrmse, m.max_abs_error, bits);
  return {{"what", what}, {"snr_db", m.snr_db}, {"psnr_db", m.psnr_db}, {"nrmse", m.nrmse},
          {"max_abs_error", m.max_abs_error}, {"bits_per_voxel", bits}};
}


// Compresses `input` with the default TA settings and evaluates it at ranks 16, 8 and 4 (the
// rank slider), printing one table row per rank.
nlohmann::json compress_and_evaluate(const std::string& name, const fs::path& input, const fs::path& output,
                                     ProgressSink& progress) {
  auto source = io::open_volume(input);
  ta::CompressParams params;
  const ta::CompressReport c = ta::compress_volume(*source, output, params, progress);
  ta::TaVolume volume(output);
  const ta::StorageReport s = ta::storage_report(volume);
  const double bpv = s.bits_per_voxel(s.file_bytes, volume.source_info());
  nlohmann::json rows = nlohmann::json::array();
  for (int k : {16, 8, 4}) {
    const ta::ErrorReport e = ta::error_report(volume, *source, k);
    std::printf("  %-22s %6.3f bits/vox  rank %2d  SNR %6.2f dB  PSNR %6.2f dB  NRMSE %.4f  compress %.1f Mvox/s  decode %.0f Mvox/s\n",
                name.c_str(), bpv, k, e.metrics.snr_db, e.metrics.psnr_db, e.metrics.nrmse,
                double(c.input_voxels) / c.seconds / 1e6, double(c.input_voxels) / e.decode_seconds / 1e6);
    rows.push_back({{"rank", k}, {"snr_db", e.metrics.snr_db}, {"psnr_db", e.metrics.psnr_db}, {"nrmse", e.metrics.nrmse}});
  }
  return {{"name", name}, {"file", output.string()}, {"bits_per_voxel", bpv}, {"compress_seconds", c.seconds},
          {"ranks", rows}};
}

// Encodes a label volume as a Mixture Graph (with the segment names of `names`, when given),
// checks level 0 decodes bit-exactly, and answers a box-histogram query by footprint assembly
// next to the exact level-0 scan.
nlohmann::json encode_and_query_labels(const std::string& name, const Volume& labels, const fs::path& output,
                                       ProgressSink& progress, const std::optional<fs::path>& names = {}) {
  mixture::EncodeOptions options;
  if (names) options.names = mixture::load_label_names(*names);
  const mixture::EncodeReport r = mixture::encode_labels(labels, output, options, progress);
  mixture::EncodedLabels encoded(output);
  const bool exact = encoded.decode_level0() == labels;
  if (!exact) throw Error("demo: level 0 of " + output.string() + " does not decode to the input labels");
  const Extent d = labels.dims();
  const Box box{{d.x / 4, d.y / 4, d.z / 4}, {d.x / 4 + d.x / 2, d.y / 4 + d.y / 2, d.z / 4 + d.z / 2}};
  const mixture::BoxQuery query(encoded, encoded.lookup(), std::uint32_t(encoded.label_map().size()));
  const mixture::BoxHistogram fast = query.hybrid(box), exact_counts = query.naive(box);
  double max_dev = 0, max_sigma = 0;
  for (const auto& c : exact_counts.counts) {
    const mixture::BoxCount* f = fast.find(c.source);
    max_dev = std::max(max_dev, std::abs((f ? f->count : 0.0) - c.count));
    if (f) max_sigma = std::max(max_sigma, f->sigma);
  }
  std::printf("  %-22s %llu nodes, depth %u, %.3f bits/voxel, max l1 %.4f, level 0 bit-exact: %s, encode %.2f s\n",
              name.c_str(), (unsigned long long)r.nodes, r.depth, r.bits_per_voxel, r.max_l1.value_or(0.0),
              exact ? "yes" : "NO", r.seconds);
  std::printf("  query %s: %zu labels, %llu fetches (naive %llu), max |count - exact| %.1f voxels (sigma up to %.1f)\n",
              box.to_string().c_str(), fast.counts.size(), (unsigned long long)fast.fetches,
              (unsigned long long)exact_counts.fetches, max_dev, max_sigma);
  return {{"name", name}, {"nodes", r.nodes}, {"depth", r.depth}, {"bits_per_voxel", r.bits_per_voxel},
          {"max_l1", r.max_l1.value_or(0.0)}, {"level0_bit_exact", exact}, {"query_box", box.to_string()},
          {"query_fetches", fast.fetches}, {"naive_fetches", exact_counts.fetches}, {"query_max_deviation", max_dev}};
}

// Renders one exact 512x384 frame at `rank` (0 = stored) into `png` and prints its figures.
nlohmann::json render_still(render::RenderSession& session, render::FrameSettings settings, const std::string& what,
                            const fs::path& png) {
  settings.camera.width = 512;
  settings.camera.height = 384;
  nlohmann::json stats;
  render::write_png(session.frame(settings, stats), png);
  const nlohmann::json& r = stats["render"];
  std::printf("  %-24s -> %s: %.0f ms, %llu samples", what.c_str(), png.filename().c_str(), stats["frame_ms"].get<double>(),
              (unsigned long long)r.value("samples", std::uint64_t(0)));
  if (stats.contains("load"))
    std::printf(", %llu bricks in the cut (%llu hits, %llu misses), %s read, decode %.0f ms, ray casting %.0f ms",
                (unsigned long long)stats["selection"]["bricks"].get<std::uint64_t>(),
                (unsigned long long)stats["load"]["cache_hits"].get<std::uint64_t>(),
                (unsigned long long)stats["load"]["cache_misses"].get<std::uint64_t>(),
                human_bytes(stats["load"]["bytes_read"].get<std::uint64_t>()).c_str(),
                stats["load"]["decode_ms"].get<double>(), r.value("raycast_ms", 0.0));
  else
    std::printf(", palette %.1f ms, ids decoded %llu, %llu empty cubes skipped", r.value("palette_ms", 0.0),
                (unsigned long long)r.value("ids_decoded", std::uint64_t(0)),
                (unsigned long long)r.value("skipped_cubes", std::uint64_t(0)));
  std::printf("\n");
  stats["image"] = png.string();
  return stats;
}

// The MRI at ranks 16, 8 and 4 (the rank slider: one session, so the compressed bricks are read
// once and only reconstructed again), and a label atlas coloured per label.
nlohmann::json render_samples(const fs::path& out) {
  nlohmann::json frames = nlohmann::json::array();
  if (fs::exists(out / "ch2better.strata")) {
    render::RenderSession session(out / "ch2better.strata");
    render::FrameSettings settings;
    settings.tf = std::make_shared<const render::TransferFunction>(render::TransferFunction::preset("mri"));
    for (int k : {16, 8, 4}) {
      settings.rank = k;
      frames.push_back(render_still(session, settings, "ch2better rank " + std::to_string(k),
                                    out / ("ch2better_rank" + std::to_string(k) + std::string(io::kPngExtension))));
    }
  }
  const fs::path labels = fs::exists(out / "aal.strata") ? out / "aal.strata" : out / "cells.strata";
  render::RenderSession session(labels);
  frames.push_back(render_still(session, {}, labels.stem().string() + " labels",
                                out / (labels.stem().string() + std::string(io::kPngExtension))));
  return frames;
}

void run_demo(const DemoArgs& args, const GlobalOptions& global) {
  auto progress = global.make_progress();
  const fs::path out = args.output_dir;
  fs::create_directories(out);
  nlohmann::json report;

  std::printf("Generating synthetic volumes (%lld^3) into %s/\n", (long long)args.size, out.c_str());
  gen::Params scalar{gen::Kind::prisms, {args.size, args.size, args.size}, 7, 0, std::nullopt};
  gen::Params labels{gen::Kind::voronoi, {args.size, args.size, args.size}, 7, 64, std::nullopt};
  gen::generate_to_file(scalar, out / "prisms.nrrd", *progress);
  gen::generate_to_file(labels, out / "cells.nrrd", *progress);

  std::printf("Converting NRRD -> NIfTI -> TIFF and checking the round trip\n");
  Volume prisms = io::read_volume(out / "prisms.nrrd");
  Volume cells = io::read_volume(out / "cells.nrrd");
  io::write_volume(out / "prisms.nii.gz", prisms);
  io::write_volume(out / "cells.tif", cells);
  const bool exact = io::read_volume(out / "prisms.nii.gz") == prisms && io::read_volume(out / "cells.tif") == cells;
  std::printf("  round trip bit-exact: %s\n", exact ? "yes" : "NO");
  if (!exact) throw Error("demo: format round trip changed the data");
  report["round_trip_bit_exact"] = exact;

  std::printf("Statistics\n");
  report["volumes"].push_back(stats_json("prisms (generated)", prisms));
  report["volumes"].push_back(stats_json("cells (generated)", cells));
  const fs::path ch2 = "/usr/share/mricron/templates/ch2better.nii.gz";
  const fs::path aal = "/usr/share/mricron/templates/aal.nii.gz";
  if (fs::exists(ch2)) report["volumes"].push_back(stats_json("ch2better.nii.gz", io::read_volume(ch2)));
  // The atlas is read once: statistics now, Mixture Graph encoding below.
  const std::optional<Volume> atlas = fs::exists(aal) ? std::optional<Volume>(io::read_volume(aal)) : std::nullopt;
  if (atlas) report["volumes"].push_back(stats_json("aal.nii.gz", *atlas));

  std::printf("Error metrics (baseline: 8-bit requantization)\n");
  report["metrics"].push_back(metrics_line("prisms u16 -> 8 bit", compare_volumes(prisms, requantize_8bit(prisms)), 8.0));

  std::printf("Tensor-approximation compression (brick 32, rank 16, u16,b8log+, zstd)\n");
  report["compression"].push_back(compress_and_evaluate("prisms (generated)", out / "prisms.nrrd", out / "prisms.strata", *progress));
  if (fs::exists(ch2)) report["compression"].push_back(compress_and_evaluate("ch2better MRI", ch2, out / "ch2better.strata", *progress));
  // The same brain at 1 mm lies on the atlas's grid: `strata serve demo-out/` overlays the two.
  const fs::path ch2_atlas_grid = "/usr/share/mricron/templates/ch2.nii.gz";
  if (atlas && fs::exists(ch2_atlas_grid))
    report["compression"].push_back(
        compress_and_evaluate("ch2 MRI (1 mm, atlas grid)", ch2_atlas_grid, out / "ch2.strata", *progress));

  std::printf("Mixture Graph for label volumes (9-bit weights, block-palette ids)\n");
  report["labels"].push_back(encode_and_query_labels("cells (generated)", cells, out / "cells.strata", *progress));
  if (atlas)  // with MRIcron's region names (aal.nii.txt beside it), which the viewer searches
    report["labels"].push_back(
        encode_and_query_labels("aal atlas", *atlas, out / "aal.strata", *progress, mixture::sidecar_label_names(aal)));

  std::printf("Rendering from the compressed files (CPU ray casting, 512x384)\n");
  report["renders"] = render_samples(out);
  write_json_file(out / "report.json", report);
  std::printf("Wrote %s\n", (out / "report.json").c_str());
}

}  // namespace

void register_demo(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<DemoArgs>();
  CLI::App* cmd = app.add_subcommand("demo", "Run the main job on the sample data and write demo-out/");
  cmd->add_option("-o,--output", args->output_dir, "Output folder")->capture_default_str();
  cmd->add_option("--size", args->size, "Edge length of the generated volumes")->capture_default_str()->check(CLI::Range(8, 2048));
  cmd->callback([args, &global] { run_demo(*args, global); });
}

}  // namespace strata::cli
