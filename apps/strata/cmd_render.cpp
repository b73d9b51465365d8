// `strata render IN.strata -o out.png`: CPU ray casting straight from a compressed file.
// TA files go through the LOD cut, the brick cache and the loader (paper 1, §3/§6); label files
// through the Mixture Graph palette (paper 4, §4). `--orbit N` writes N frames around the volume.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/lod/brick_provider.hpp"
#include "strata/lod/selection.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/image.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/label_color_map.hpp"
#include "strata/render/label_raycaster.hpp"
#include "strata/render/label_scene.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/transfer_function.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::cli {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

struct RenderArgs {
  std::string input, output, size = "1024x768", tf = "ct", shading = "on", stats, colors, background = "0,0,0";
  double azimuth = 30, elevation = 20, distance = 0, fov = 30, lod = 1.0, step = 0.5, lod_bias = 0.0;
  int rank = 0, orbit = 0;
  bool exact = false, ortho = false;
  std::string cache = "1G";
  std::int64_t max_bricks = 8192;
};

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

std::pair<int, int> parse_size(const std::string& text) {
  const auto x = text.find('x');
  try {
    if (x == std::string::npos) throw std::invalid_argument("no x");
    const int w = std::stoi(text.substr(0, x)), h = std::stoi(text.substr(x + 1));
    if (w > 0 && h > 0 && w <= 16384 && h <= 16384) return {w, h};
  } catch (const std::exception&) {
  }
  throw Error("--size: expected WIDTHxHEIGHT (1..16384 each), got '" + text + "'");
}

std::array<float, 4> parse_background(const std::string& text) {
  std::array<float, 4> c{0, 0, 0, 1};
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', start);
    if ((i < 2) != (comma != std::string::npos))
      throw Error("--background: expected r,g,b in [0,1], got '" + text + "'");
    try {
      c[std::size_t(i)] = std::stof(text.substr(start, comma - start));
    } catch (const std::exception&) {
      throw Error("--background: expected r,g,b in [0,1], got '" + text + "'");
    }
    if (!(c[std::size_t(i)] >= 0 && c[std::size_t(i)] <= 1))
      throw Error("--background: components must lie in [0,1], got '" + text + "'");
    start = comma + 1;
  }
  return c;
}

render::CameraSpec camera_spec(const RenderArgs& a, double azimuth) {
  render::CameraSpec spec;
  std::tie(spec.width, spec.height) = parse_size(a.size);
  spec.projection = a.ortho ? render::Projection::orthographic : render::Projection::perspective;
  spec.fov_deg = a.fov;
  spec.orbit.azimuth_deg = azimuth;
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

// One frame of a TA file: LOD cut -> brick provider -> ray caster.
struct ScalarSession {
  ta::TaVolume volume;
  lod::BrickProvider provider;
  render::RayCaster caster;
  std::uint64_t visible_bins;
  lod::SelectionOptions selection;

  ScalarSession(const RenderArgs& a, render::RenderOptions options, lod::ProviderOptions provider_options)
      : volume(a.input),
        provider(volume, provider_options),
        caster(render::TransferFunction::from_argument(a.tf), options),
        visible_bins(caster.transfer_function().visible_bins(volume.value_min(), volume.value_max())) {
    selection.lod = a.lod;
    selection.max_bricks = a.max_bricks;
    selection.memory_budget = provider_options.cache_bytes;
  }

  render::Image frame(const render::Camera& camera, int rank, bool exact, nlohmann::json& stats) {
    const auto t0 = Clock::now();
    const lod::Selection cut = lod::select_cut(volume, camera.view(), visible_bins, selection);
    const double select_ms = ms_since(t0);
    const int k = rank > 0 ? rank : volume.rank();  // 0 = the stored rank
    const lod::FrameBricks bricks = provider.acquire(cut, k, exact);
    render::FrameInput input;
    input.bricks = &bricks;
    input.geometry = &volume.geometry();
    input.spacing = volume.source_info().spacing;
    input.value_min = volume.value_min();
    input.value_max = volume.value_max();
    input.index = &volume.container();
    render::RenderStats rs;
    render::Image image = caster.render(camera, input, &rs);
    stats = render::stats_json(rs, &bricks.stats);
    stats["selection"] = {{"bricks", cut.bricks.size()},  {"per_level", cut.per_level},
                          {"bytes", cut.bytes},           {"budget_hit", cut.budget_hit()},
                          {"culled_frustum", cut.culled_frustum}, {"culled_empty", cut.culled_empty},
                          {"select_ms", select_ms}};
    stats["rank"] = provider.clamp_rank(k);
    return image;
  }
};

// One frame of a label file: palette through the Mixture Graph, then the label ray caster. The
// scene keeps decoded node ids, so later frames only march (and recolour when asked).
struct LabelSession {
  mixture::EncodedLabels labels;
  render::LabelScene scene;
  render::LabelRenderOptions options;

  LabelSession(const RenderArgs& a, const render::RenderOptions& o)
      : labels(a.input),
        scene(labels, a.colors.empty() ? render::LabelColorMap{} : render::LabelColorMap::load(a.colors)) {
    options.lod_bias = a.lod_bias;
    options.step = o.step;
    options.shading = o.shading;
    options.background = {o.background[0], o.background[1], o.background[2], o.background[3]};
  }

  render::Image frame(const render::Camera& camera, nlohmann::json& stats) {
    render::LabelRenderStats st;
    render::Image image = render::render_labels(scene, camera, options, &st);
    stats["render"] = {{"ms", st.ms},
                       {"march_ms", st.march_ms},
                       {"palette_ms", st.palette_ms},
                       {"ids_ms", st.ids_ms},
                       {"skip_grid_ms", st.skip_grid_ms},
                       {"ids_decoded", st.ids_decoded},
                       {"rays", st.rays},
                       {"samples", st.samples},
                       {"skipped_cubes", st.skipped_cubes},
                       {"terminated_rays", st.terminated_rays},
                       {"levels", {st.finest_level, st.coarsest_level}}};
    return image;
  }
};

nlohmann::json summary(const nlohmann::json& frames) {
  double total = 0, decode = 0, cpu = 0;
  for (const auto& f : frames) {
    total += f.value("frame_ms", 0.0);
    cpu += f.value("cpu_s", 0.0);
    if (f.contains("load")) decode += f["load"].value("decode_ms", 0.0);
  }
  const double n = double(std::max<std::size_t>(1, frames.size()));
  return {{"frames", frames.size()},
          {"mean_frame_ms", total / n},
          {"frames_per_s", total > 0 ? 1000.0 * n / total : 0.0},
          {"cpu_s_per_frame", cpu / n},
          {"decode_share", total > 0 ? decode / total : 0.0}};
}

void print_frame(const fs::path& path, const nlohmann::json& s) {
  std::printf("%s: %.1f ms", path.string().c_str(), s.value("frame_ms", 0.0));
  if (s.contains("selection"))
    std::printf(" (%llu bricks in the cut, %llu drawn", (unsigned long long)s["selection"]["bricks"].get<std::uint64_t>(),
                (unsigned long long)s["load"].value("resident", std::uint64_t(0)));
  if (s.contains("load"))
    std::printf(", %llu hits / %llu misses, %s read, decode %.1f ms)",
                (unsigned long long)s["load"].value("cache_hits", std::uint64_t(0)),
                (unsigned long long)s["load"].value("cache_misses", std::uint64_t(0)),
                human_bytes(s["load"].value("bytes_read", std::uint64_t(0))).c_str(), s["load"].value("decode_ms", 0.0));
  std::printf("\n");
}

void run_render(const RenderArgs& a, const GlobalOptions&) {
  if (a.orbit < 0) throw Error("--orbit: must be >= 0");
  if (!(a.step > 0)) throw Error("--step: must be positive");
  if (a.shading != "on" && a.shading != "off") throw Error("--shading: expected on or off, got '" + a.shading + "'");
  render::RenderOptions options;
  options.step = a.step;
  options.shading = a.shading == "on";
  options.background = parse_background(a.background);
  if (a.orbit > 0) fs::create_directories(a.output);

  const store::ContainerReader probe(a.input);
  const bool labels = probe.metadata().value("codec", std::string()) == "mixture-graph";
  std::optional<ScalarSession> scalar;
  std::optional<LabelSession> label;
  Extent dims;
  Spacing spacing;
  if (labels) {
    label.emplace(a, options);
    dims = label->labels.level_dims(0);
    spacing = label->labels.spacing();
  } else {
    lod::ProviderOptions po;
    po.cache_bytes = parse_byte_size(a.cache, "--cache");
    scalar.emplace(a, options, po);
    dims = scalar->volume.source_info().dims;
    spacing = scalar->volume.source_info().spacing;
  }

  nlohmann::json frames = nlohmann::json::array();
  const int count = std::max(1, a.orbit);
  for (int i = 0; i < count; ++i) {
    const render::Camera camera(camera_spec(a, frame_azimuth(a, i)), dims, spacing);
    const double c0 = cpu_seconds();
    const auto t0 = Clock::now();
    nlohmann::json s;
    // A still, and the first frame of an orbit, show the complete cut; later orbit frames
    // draw what is resident and let the loader catch up, unless --exact.
    const render::Image image = labels ? label->frame(camera, s) : scalar->frame(camera, a.rank, a.exact || i == 0, s);
    s["frame_ms"] = ms_since(t0);
    s["cpu_s"] = cpu_seconds() - c0;
    s["frame"] = i;
    s["azimuth"] = frame_azimuth(a, i);
    const fs::path path = frame_path(a, i);
    render::write_png(image, path);
    print_frame(path, s);
    frames.push_back(std::move(s));
  }
  if (!a.stats.empty()) write_json_file(a.stats, {{"input", a.input}, {"summary", summary(frames)}, {"frames", frames}});
  if (a.orbit > 0) {
    const nlohmann::json sum = summary(frames);
    std::printf("%d frames: %.1f ms mean, %.1f frames/s, %.3f CPU s per frame, decode share %.1f%%\n", count,
                sum["mean_frame_ms"].get<double>(), sum["frames_per_s"].get<double>(),
                sum["cpu_s_per_frame"].get<double>(), 100.0 * sum["decode_share"].get<double>());
  }
}

}  // namespace

void register_render(CLI::App& app, const GlobalOptions& global) {
  auto a = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "Ray-cast a .strata file (TA volume or label volume) to PNG");
  cmd->add_option("input", a->input, "Input .strata file")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", a->output, "Output PNG (with --orbit: a folder of frame_NNNN.png)")->required();
  cmd->add_option("--size", a->size, "Image size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--azimuth", a->azimuth, "Degrees around the volume's z axis")->capture_default_str();
  cmd->add_option("--elevation", a->elevation, "Degrees above the xy plane")->capture_default_str();
  cmd->add_option("--distance", a->distance, "Distance from the volume centre in world units (0 = fit)")
      ->capture_default_str();
  cmd->add_option("--fov", a->fov, "Vertical field of view in degrees (perspective)")->capture_default_str();
  cmd->add_flag("--ortho", a->ortho, "Orthographic projection");
  cmd->add_option("--tf", a->tf, "Transfer function: a preset (grayscale, ct, bone, mri, fire) or a JSON file")
      ->capture_default_str();
  cmd->add_option("--rank", a->rank, "Reconstruction rank K (0 = the stored rank): the feature-scale slider")
      ->capture_default_str();
  cmd->add_option("--lod", a->lod, "Refine bricks while a voxel covers more than this many pixels")
      ->capture_default_str();
  cmd->add_option("--shading", a->shading, "Blinn-Phong shading: on | off")->capture_default_str();
  cmd->add_option("--step", a->step, "Sample distance in voxels of the sampled level")->capture_default_str();
  cmd->add_option("--background", a->background, "Background colour r,g,b in [0,1]")->capture_default_str();
  cmd->add_flag("--exact", a->exact, "Wait for every brick of the cut in every frame (no progressive refinement)");
  cmd->add_option("--orbit", a->orbit, "Render N frames around the volume into the output folder")
      ->capture_default_str();
  cmd->add_option("--stats", a->stats, "Write per-frame statistics as JSON");
  cmd->add_option("--cache", a->cache, "Brick cache and LOD memory budget (e.g. 512M, 2G)")->capture_default_str();
  cmd->add_option("--max-bricks", a->max_bricks, "Brick budget of the LOD cut")->capture_default_str();
  cmd->add_option("--colors", a->colors, "Label files: JSON colour map (default: a hash colour per label)");
  cmd->add_option("--lod-bias", a->lod_bias, "Label files: added to the mip level chosen per sample")
      ->capture_default_str();
  cmd->callback([a, &global] { run_render(*a, global); });
}

}  // namespace strata::cli
