// `strata render IN.strata -o out.png`: CPU ray casting straight from a compressed file.
// TA files go through the LOD cut, the brick cache and the loader (paper 1, §3/§6); label files
// through the Mixture Graph palette (paper 4, §4). `--orbit N` writes N frames around the volume.
#include <cstdio>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_checks.hpp"
#include "strata/ta/codec_names.hpp"
#include "commands.hpp"
#include "strata/ta/global_basis.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/http_source.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"
#include "strata/render/render_session.hpp"

namespace strata::cli {

namespace fs = std::filesystem;

namespace {

// --tf: the preset the data suggests (RenderSession::default_preset).
constexpr std::string_view kAutoPreset = "auto";
// --orbit: at most one frame per tenth of a degree.
constexpr int kMaxOrbitFrames = 3600;
// --passes: beyond this the mean of jittered passes changes by less than an 8-bit level.
constexpr int kMaxPasses = 256;

struct RenderArgs {
  std::string input, output, size = "1024x768", tf = std::string(kAutoPreset), shading = "on", stats, colors, background = "0,0,0",
      lighting = "auto";
  double azimuth = 30, elevation = 20, distance = 0, fov = 30, lod = 1.0, step = 0.5, lod_bias = 0.0, target_fps = 0,
         feature_scale = 0;
  int rank = 0, orbit = 0, passes = 1;
  bool exact = false, ortho = false;
  std::string jitter = "on";
  std::string cache = "1G";
  std::int64_t max_bricks = 8192;
  std::optional<std::int64_t> volume;
};

std::pair<int, int> parse_size(const std::string& text) {
  const auto x = text.find('x');
  try {
    if (x == std::string::npos) throw std::invalid_argument("no x");
    std::size_t used_w = 0, used_h = 0;
    const int w = std::stoi(text.substr(0, x), &used_w), h = std::stoi(text.substr(x + 1), &used_h);
    const bool whole = used_w == x && used_h == text.size() - x - 1;
    if (whole && w > 0 && h > 0 && w <= render::kMaxImageEdge && h <= render::kMaxImageEdge) return {w, h};
  } catch (const std::exception&) {
  }
  throw UsageError("--size", fmt::format("expected WIDTHxHEIGHT (1..{} each), got '{}'", render::kMaxImageEdge, text));
}

std::array<float, 4> parse_background(const std::string& text) {
  std::array<float, 4> c{0, 0, 0, 1};
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', start);
    if ((i < 2) != (comma != std::string::npos))
      throw UsageError("--background", "expected r,g,b in [0,1], got '" + text + "'");
    try {
      c[std::size_t(i)] = std::stof(text.substr(start, comma - start));
    } catch (const std::exception&) {
      throw UsageError("--background", "expected r,g,b in [0,1], got '" + text + "'");
    }
    if (!(c[std::size_t(i)] >= 0 && c[std::size_t(i)] <= 1))
      throw UsageError("--background", "components must lie in [0,1], got '" + text + "'");
    start = comma + 1;
  }
  return c;
}

// The camera of every frame but its azimuth (frame_azimuth). Throws Error on a bad --size.
render::CameraSpec camera_spec(const RenderArgs& a) {
  render::CameraSpec spec;
  std::tie(spec.width, spec.height) = parse_size(a.size);
  spec.projection = a.ortho ? render::Projection::orthographic : render::Projection::perspective;
  spec.fov_deg = a.fov;
  spec.orbit.elevation_deg = a.elevation;
  spec.orbit.distance = a.distance;
  return spec;
}

// Where frame `i` goes: the file itself for a still, `<dir>/frame_0000.png` for an orbit.
fs::path frame_path(const RenderArgs& a, int i) {
  if (a.orbit == 0) return a.output;
  return fs::path(a.output) / fmt::format("frame_{:04d}.png", i);
}

double frame_azimuth(const RenderArgs& a, int i) { return a.orbit == 0 ? a.azimuth : a.azimuth + 360.0 * i / a.orbit; }

void print_frame(const fs::path& path, const nlohmann::json& s) {
  std::printf("%s: %.1f ms", path.string().c_str(), s.value("frame_ms", 0.0));
  if (s.value("image_scale", 1.0) > 1.0) std::printf(" (rays on a 1/%.2f grid)", s["image_scale"].get<double>());
  if (s.contains("selection"))
    std::printf(" (%llu bricks in the cut, %llu drawn", (unsigned long long)s["selection"]["bricks"].get<std::uint64_t>(),
                (unsigned long long)s["load"].value("resident", std::uint64_t(0)));
  if (s.contains("load"))
    std::printf(", %llu hits / %llu misses, %s read, decode %.1f ms)",
                (unsigned long long)s["load"].value("cache_hits", std::uint64_t(0)),
                (unsigned long long)s["load"].value("cache_misses", std::uint64_t(0)),
                human_bytes(s["load"].value("bytes_read", std::uint64_t(0))).c_str(), s["load"].value("decode_ms", 0.0));
  std::printf("\n");
  if (s.contains("selection") && s["selection"].contains("per_rank")) {
    // Alg. 2's choice: bricks per level (finest first) and per rank.
    std::string levels, ranks;
    const auto& per_level = s["selection"]["per_level"];
    for (std::size_t l = 0; l < per_level.size(); ++l)
      if (per_level[l].get<std::int64_t>() > 0) levels += fmt::format(" L{}:{}", l, per_level[l].get<std::int64_t>());
    std::map<int, std::int64_t> per_rank;  // JSON keys are text: "12" would sort before "4"
    for (const auto& [k, count] : s["selection"]["per_rank"].items()) per_rank[std::stoi(k)] = count.get<std::int64_t>();
    for (const auto& [k, count] : per_rank) ranks += fmt::format(" K{}:{}", k, count);
    std::printf("  feature scale %g: bricks per level%s; per rank%s\n", s["selection"]["feature_scale"].get<double>(),
                levels.c_str(), ranks.c_str());
  }
}

void print_summary(const char* what, const nlohmann::json& sum) {
  std::printf("%s: %llu frames, %.1f ms mean, %.1f frames/s, %.3f CPU s per frame, decode share %.1f%%\n", what,
              (unsigned long long)sum["frames"].get<std::uint64_t>(), sum["mean_frame_ms"].get<double>(),
              sum["frames_per_s"].get<double>(), sum["cpu_s_per_frame"].get<double>(),
              100.0 * sum["decode_share"].get<double>());
}

// Checked by the library (validate(SessionOptions)) before the file is opened.
render::SessionOptions session_options(const RenderArgs& a) {
  render::SessionOptions s;
  s.background = parse_background(a.background);
  s.cache_bytes = parse_byte_size(a.cache, "--cache");
  s.max_bricks = a.max_bricks;
  s.target_fps = a.target_fps;
  s.volume = a.volume;
  as_usage_error([&] { render::validate(s); });
  return s;
}

// Everything but the quality, which changes per frame; checked by the library
// (validate(FrameSettings)) for every azimuth of the run before any work.
render::FrameSettings frame_settings(const RenderArgs& a) {
  if (a.shading != "on" && a.shading != "off")
    throw UsageError("--shading", "expected on or off, got '" + a.shading + "'");
  render::FrameSettings f;
  f.camera = camera_spec(a);
  f.rank = a.rank;
  f.lod = a.lod;
  f.feature_scale = a.feature_scale;
  f.lod_bias = a.lod_bias;
  if (a.lighting == "auto") f.label_lighting = render::LabelLightingChoice::automatic;
  else if (a.lighting == "gradient") f.label_lighting = render::LabelLightingChoice::gradient;
  else if (a.lighting == "gradient-ao") f.label_lighting = render::LabelLightingChoice::gradient_occlusion;
  else if (a.lighting == "normals") f.label_lighting = render::LabelLightingChoice::normals;
  else throw UsageError("--lighting", "expected auto, gradient, gradient-ao or normals, got '" + a.lighting + "'");
  f.step = a.step;
  f.shading = a.shading == "on";
  if (a.jitter != "on" && a.jitter != "off") throw UsageError("--jitter", "expected on or off, got '" + a.jitter + "'");
  f.jitter = a.jitter == "on";
  if (a.passes < 1 || a.passes > kMaxPasses)
    throw UsageError("--passes", fmt::format("must lie in 1..{}, got {}", kMaxPasses, a.passes));
  as_usage_error([&] {
    for (const int i : {0, std::max(0, a.orbit - 1)}) {
      f.camera.orbit.azimuth_deg = frame_azimuth(a, i);
      render::validate(f);
    }
  });
  if (a.tf != kAutoPreset)  // else chosen once the input is open (run_render)
    f.tf = std::make_shared<const render::TransferFunction>(render::TransferFunction::from_argument(a.tf));
  return f;
}

// The files this run reads, and where it writes: refused before any work when an output is an
// input, has the wrong extension or cannot be written.
void check_outputs(const RenderArgs& a) {
  std::vector<std::string> inputs{a.input, a.colors};
  if (a.tf != kAutoPreset && !render::TransferFunction::is_preset(a.tf)) inputs.push_back(a.tf);
  if (a.orbit > 0) {
    check_output_folder(a.output, "--output", inputs);
    std::vector<fs::path> frames;
    for (int i = 0; i < a.orbit; ++i) frames.push_back(frame_path(a, i));
    check_spares_inputs(frames, "--output", inputs);
  } else {
    check_output_file(a.output, "--output", inputs, {io::kPngExtension});
  }
  if (a.stats.empty()) return;
  check_output_file(a.stats, "--stats", inputs, {io::kJsonExtension});
  if (a.orbit == 0) check_distinct_outputs(a.output, "--output", a.stats, "--stats");
}

// A still, and the first frame of an orbit, show the complete cut; later orbit frames draw
// what is resident and let the loader catch up (on a coarser ray grid with --target-fps),
// unless --exact.
render::FrameQuality frame_quality(const RenderArgs& a, int i) {
  if (a.exact || i == 0) return render::FrameQuality::exact;
  return a.target_fps > 0 ? render::FrameQuality::interactive : render::FrameQuality::progressive;
}

// The mean of `passes` frames with jitter patterns 0..passes-1 (one frame when 1): `s` holds
// the first frame's figures, with the passes' total time and CPU.
render::Image refined_frame(render::RenderSession& session, render::FrameSettings settings, int passes,
                            nlohmann::json& s) {
  settings.pass = 0;
  render::Image first = session.frame(settings, s);
  if (passes == 1) return first;
  render::ImageMean mean;
  mean.add(first);
  for (int p = 1; p < passes; ++p) {
    nlohmann::json more;
    settings.pass = std::uint32_t(p);
    mean.add(session.frame(settings, more));
    for (const char* key : {"frame_ms", "cpu_s"})
      if (s.contains(key) && more.contains(key)) s[key] = s[key].get<double>() + more[key].get<double>();
  }
  s["passes"] = passes;
  return mean.mean();
}

void run_render(const RenderArgs& a, const GlobalOptions&) {
  if (a.orbit < 0 || a.orbit > kMaxOrbitFrames)
    throw UsageError("--orbit", fmt::format("must lie in 0..{} frames, got {}", kMaxOrbitFrames, a.orbit));
  render::FrameSettings settings = frame_settings(a);
  const render::SessionOptions options = session_options(a);
  check_outputs(a);
  render::RenderSession session(a.input, options);
  if (!settings.tf)
    settings.tf = std::make_shared<const render::TransferFunction>(render::TransferFunction::preset(session.default_preset()));
  check_rank_flag(a.rank, session.stored_rank(), a.input);
  if (settings.label_lighting == render::LabelLightingChoice::normals &&
      !session.has_normals())
    throw UsageError("--lighting", a.input + " has no normals graph: normals lighting needs a label file encoded with "
                                             "strata labels encode --normals");
  if (a.feature_scale > 0 && !session.has_feature_scale())
    throw UsageError("--feature-scale", a.input + " has no feature-scale table: an error target needs a " +
                                            ta::kGlobalCodecName + " file (strata compress --codec " +
                                            ta::kGlobalCodecName + ")");
  if (!a.colors.empty() && session.kind() == render::DatasetKind::labels)
    session.set_label_colors(render::LabelColorMap::load(a.colors));
  OutputSet outputs;  // removed again unless every frame and the statistics are written
  if (a.orbit > 0 && !fs::exists(a.output)) {
    fs::create_directories(a.output);
    outputs.created_folder(a.output);
  }
  nlohmann::json frames = nlohmann::json::array();
  const int count = std::max(1, a.orbit);
  for (int i = 0; i < count; ++i) {
    nlohmann::json s;
    settings.camera.orbit.azimuth_deg = frame_azimuth(a, i);
    settings.quality = frame_quality(a, i);
    const render::Image image = refined_frame(session, settings, a.passes, s);
    s["frame"] = i;
    s["azimuth"] = settings.camera.orbit.azimuth_deg;
    const fs::path path = frame_path(a, i);
    render::write_png(image, path);
    outputs.add(path);
    print_frame(path, s);
    frames.push_back(std::move(s));
  }
  const nlohmann::json sum = render::frame_summary(frames);
  if (!a.stats.empty()) {
    nlohmann::json stats{{"input", a.input}, {"summary", sum}, {"frames", frames}};
    if (const auto transfer = io::transfer_stats_of(a.input)) stats["transfer"] = transfer_json(*transfer);
    write_json_file(a.stats, stats);
  }
  outputs.commit();
  if (a.orbit > 0) print_summary("all frames", sum);
  if (sum.contains("after_first")) print_summary("after the first", sum["after_first"]);
}

}  // namespace

void register_render(CLI::App& app, const GlobalOptions& global) {
  auto a = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Ray-cast a .strata file (TA or label volume), or a plain volume file loaded whole, to PNG");
  // A local input must exist; a URL is checked when it is opened. (Strata's words, not CLI11's
  // "File is actually a directory".)
  const CLI::Validator file_or_url(
      [](std::string& s) -> std::string {
        std::error_code ec;
        const fs::file_status status = fs::status(s, ec);
        if (io::is_url(s) || (fs::exists(status) && !fs::is_directory(status))) return {};
        return "'" + s + "' " + (fs::is_directory(status) ? "is a folder" : "does not exist") +
               ", expected a .strata file, a volume file or an http(s) URL";
      },
      "FILE|URL");
  cmd->add_option("input", a->input,
                  "Input .strata file (or its http(s) URL), or a raw/NRRD/NIfTI/TIFF volume (loaded whole)")
      ->required()
      ->check(file_or_url);
  cmd->add_option("-o,--output", a->output, "Output PNG (with --orbit: a folder of frame_NNNN.png)")->required();
  cmd->add_option("--size", a->size, "Image size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--azimuth", a->azimuth, "Degrees around the volume's z axis (finite, |A| <= 1e6)")->capture_default_str();
  cmd->add_option("--elevation", a->elevation, "Degrees above the xy plane (-90..90)")->capture_default_str();
  cmd->add_option("--distance", a->distance, "Distance from the volume centre in world units (0 = fit; at most 1e12)")
      ->capture_default_str();
  cmd->add_option("--fov", a->fov, "Vertical field of view in degrees (perspective; between 0 and 180)")->capture_default_str();
  cmd->add_flag("--ortho", a->ortho, "Orthographic projection");
  cmd->add_option("--tf", a->tf,
                  "Transfer function: auto (the preset for the data: ct for Hounsfield units or a CT name, mri for an "
                  "MR name, a NIfTI file or a volume in RAS/LPS space, else grayscale), a preset (grayscale, ct, bone, "
                  "mri, fire) or a JSON file")
      ->capture_default_str();
  cmd->add_option("--rank", a->rank,
                  "Reconstruction rank K, 1..the stored rank (0 = the stored rank): the feature-scale slider")
      ->capture_default_str();
  cmd->add_option("--lod", a->lod, "Refine bricks while a voxel covers more than this many pixels (0 < L <= 64)")
      ->capture_default_str();
  cmd->add_option("--feature-scale", a->feature_scale,
                  std::string(ta::kGlobalCodecName) + " files: error target E, a normalized RMSE (e.g. 0.01 = 1% of the value range) that picks "
                  "each brick's rank and level from the file's feature-scale table (0 = off, the --lod rule alone)")
      ->capture_default_str();
  cmd->add_option("--shading", a->shading, "Blinn-Phong shading: on | off")->capture_default_str();
  cmd->add_option("--step", a->step, "Sample distance in voxels of the sampled level (0.05..16)")->capture_default_str();
  cmd->add_option("--jitter", a->jitter,
                  "Scalar volumes: start each pixel's samples at its own fraction of a step (on: the step's error "
                  "is fine noise, not rings; off: every ray samples at whole steps from the eye)")
      ->capture_default_str();
  cmd->add_option("--passes", a->passes,
                  "Scalar volumes: average this many jittered passes per frame (1..256; 8 removes the sampling "
                  "noise of step 0.5 and costs 8 frames)")
      ->capture_default_str();
  cmd->add_option("--background", a->background, "Background colour r,g,b in [0,1]")->capture_default_str();
  cmd->add_flag("--exact", a->exact, "Wait for every brick of the cut in every frame (no progressive refinement)");
  cmd->add_option("--orbit", a->orbit, "Render N frames around the volume into the output folder (0..3600)")
      ->capture_default_str();
  cmd->add_option("--target-fps", a->target_fps,
                  "Orbit frames after the first (not --exact): cast rays on a coarser image grid to hold this rate "
                  "(0 = full resolution; at most 1e6)")
      ->capture_default_str();
  cmd->add_option("--stats", a->stats, "Write per-frame statistics as JSON");
  cmd->add_option("--cache", a->cache, "Brick cache and LOD memory budget (e.g. 512M, 2G)")->capture_default_str();
  cmd->add_option("--max-bricks", a->max_bricks, "Brick budget of the LOD cut (>= 1)")->capture_default_str();
  cmd->add_option("--colors", a->colors, "Label files: JSON colour map (default: a hash colour per label)");
  cmd->add_option("--lighting", a->lighting,
                  "Label files, with shading: normals (the file's normals graph, `labels encode --normals`: smooth, "
                  "pre-filtered) | gradient (opacity gradients, on the fly) | gradient-ao (with local ambient occlusion) | auto "
                  "(normals when the file has them)")
      ->capture_default_str();
  cmd->add_option("--lod-bias", a->lod_bias, "Label files: added to the mip level chosen per sample (-64..64)")
      ->capture_default_str();
  add_volume_option(*cmd, a->volume);
  cmd->callback([a, &global] { run_render(*a, global); });
}

}  // namespace strata::cli
