// GET /api/datasets/{id}/render: one 3D frame through the render queue; GET .../pick: what a
// pixel of that frame shows.
#include <algorithm>
#include <cctype>

#include "server/api_detail.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/ta/codec_names.hpp"

namespace strata::server::detail {

namespace {

// The viewer stops refining long before this; beyond it a pass adds under an 8-bit level.
constexpr std::int64_t kMaxRefinementPass = 255;

struct FrameRequest {
  render::FrameSettings settings;
  bool jpeg = false;
  std::string client;
  std::optional<std::uint64_t> seq;
};

void parse_camera(const Params& p, render::CameraSpec& camera) {
  camera.width = int(p.integer("w", 1, 4096, 1024));
  camera.height = int(p.integer("h", 1, 4096, 768));
  camera.orbit.azimuth_deg = p.number("az", {-1e6, 1e6}, 30);
  camera.orbit.elevation_deg = p.number("el", {-90, 90}, 20);
  camera.orbit.distance = p.number("dist", {0, 1e12, true}, 0);
  camera.fov_deg = p.number("fov", {0, 180, true, true}, 30);
  if (const auto target = p.numbers("target", 3)) {
    camera.orbit.target = {(*target)[0], (*target)[1], (*target)[2]};
    camera.orbit.target_set = true;
  }
}

// A client id is an opaque token: short, printable, no separators that could confuse logs.
void check_client(const std::string& client) {
  const bool ok = !client.empty() && client.size() <= 64 && std::all_of(client.begin(), client.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
  });
  if (!ok) bad_parameter("client", "expected 1 to 64 characters of A-Z a-z 0-9 - _ .");
}

FrameRequest parse_frame(const Dataset& d, const HttpRequest& r) {
  const Params p(r, {"w", "h", "az", "el", "dist", "target", "fov", "tf", "rank", "lod", "fs", "lighting", "step", "shading", "pass", "quality",
                     "format", "client", "seq"});
  FrameRequest f;
  render::FrameSettings& s = f.settings;
  parse_camera(p, s.camera);
  if (const auto tf = p.text("tf")) {
    require_kind(d, {render::DatasetKind::scalar, render::DatasetKind::plain}, "tf");
    s.tf = parse_tf(*tf);
  }
  s.rank = parse_rank(p, d);
  s.lod = p.number("lod", {0, 64, true}, 1.0);
  s.feature_scale = p.number("fs", {0, 1}, 0.0);
  if (s.feature_scale > 0 && d.description.value("feature_scale_ladder", nlohmann::json::array()).empty())
    bad_parameter("fs", std::string("an error target needs the feature-scale table of a ") + ta::kGlobalCodecName +
                            " file; this one has none");
  s.step = p.number("step", {0.05, 4}, 0.5);
  s.shading = p.choice("shading", {"0", "1"}, "1") == "1";
  // Refinement at rest: the viewer averages passes 0..n-1 of the same view (docs/viewer.md).
  s.pass = std::uint32_t(p.integer("pass", 0, kMaxRefinementPass, 0));
  if (p.has("lighting")) {
    require_kind(d, {render::DatasetKind::labels}, "lighting");
    const std::string lighting = p.choice("lighting", {"auto", "gradient", "gradient-ao", "normals"}, "auto");
    if (lighting == "normals" && !d.description.value("normals", false))
      bad_parameter("lighting", "this label file has no normals graph (strata labels encode --normals)");
    s.label_lighting = lighting == "gradient"      ? render::LabelLightingChoice::gradient
                       : lighting == "gradient-ao" ? render::LabelLightingChoice::gradient_occlusion
                       : lighting == "normals" ? render::LabelLightingChoice::normals
                                               : render::LabelLightingChoice::automatic;
  }
  const bool coarse = p.choice("quality", {"coarse", "exact"}, "exact") == "coarse";
  s.quality = coarse ? render::FrameQuality::interactive : render::FrameQuality::exact;
  f.jpeg = p.choice("format", {"jpeg", "png"}, coarse ? "jpeg" : "png") == "jpeg";
  if (p.has("client") != p.has("seq")) bad_parameter(p.has("client") ? "seq" : "client", "client and seq go together");
  if (const auto client = p.text("client")) {
    check_client(*client);
    f.client = *client;
    f.seq = std::uint64_t(*p.integer("seq", 0, std::int64_t(1) << 53));
  }
  return f;
}

// The frame's figures for the X-Strata-Stats header (docs/viewer.md): a compact subset of
// what RenderSession reports.
nlohmann::json header_stats(const nlohmann::json& s, bool coarse, double queue_ms) {
  nlohmann::json j{{"frame_ms", s.value("frame_ms", 0.0)},
                   {"queue_ms", queue_ms},
                   {"quality", coarse ? "coarse" : "exact"},
                   {"image_scale", s.value("image_scale", 1.0)}};
  if (s.contains("rank")) j["rank"] = s["rank"];
  if (s.contains("selection"))
    j["selection"] = {{"bricks", s["selection"]["bricks"]},
                      {"per_level", s["selection"]["per_level"]},
                      {"budget_hit", s["selection"]["budget_hit"]}};
  if (s.contains("selection") && s["selection"].contains("per_rank")) j["selection"]["per_rank"] = s["selection"]["per_rank"];
  if (s.contains("load")) {
    const nlohmann::json& l = s["load"];
    j["load"] = {{"bricks_resident", l["resident"]}, {"bricks_loading", l["pending"]},
                 {"bytes_read", l["bytes_read"]},    {"decode_ms", l["decode_ms"]},
                 {"cache_hits", l["cache_hits"]},    {"cache_misses", l["cache_misses"]}};
  }
  if (s.contains("render")) {
    const nlohmann::json& r = s["render"];
    j["render_ms"] = r.contains("raycast_ms") ? r["raycast_ms"] : r.value("march_ms", nlohmann::json(0.0));
    if (r.contains("palette_ms")) j["palette_ms"] = r["palette_ms"];
  }
  return j;
}

}  // namespace

HttpResponse render_frame(Dataset& d, RenderQueue& queue, const HttpRequest& r) {
  FrameRequest f = parse_frame(d, r);
  const auto queued_at = SteadyClock::now();
  auto job = [&d, settings = f.settings, jpeg = f.jpeg, queued_at] {
    const double queue_ms = ms_since(queued_at);
    nlohmann::json stats;
    render::Image image;
    {
      std::lock_guard lock(d.mutex);
      image = d.session->frame(settings, stats);
    }
    HttpResponse response = jpeg ? bytes_response("image/jpeg", render::encode_jpeg(image))
                                 : bytes_response("image/png", render::encode_png(image));
    const bool coarse = settings.quality != render::FrameQuality::exact;
    response.set_header("X-Strata-Stats", header_stats(stats, coarse, queue_ms).dump());
    return response;
  };
  return queue.run(f.client, f.seq, std::move(job));
}

HttpResponse pick_voxel(Dataset& d, const HttpRequest& r) {
  const Params p(r, {"x", "y", "w", "h", "az", "el", "dist", "target", "fov", "tf", "rank"});
  render::CameraSpec camera;
  parse_camera(p, camera);
  // Pixel coordinates of the frame (pixel (0, 0) spans [-0.5, 0.5) about its centre).
  const double x = p.required_number("x", {-0.5, double(camera.width) - 0.5, false, true});
  const double y = p.required_number("y", {-0.5, double(camera.height) - 0.5, false, true});
  std::shared_ptr<const render::TransferFunction> tf;
  if (const auto text = p.text("tf")) {
    require_kind(d, {render::DatasetKind::scalar, render::DatasetKind::plain}, "tf");
    tf = parse_tf(*text);
  }
  const int rank = parse_rank(p, d);
  std::lock_guard lock(d.mutex);
  if (!tf) tf = std::make_shared<const render::TransferFunction>(render::TransferFunction::preset(d.session->default_preset()));
  const std::optional<render::Pick> pick = d.session->pick(camera, x, y, *tf, rank);
  if (!pick) return json_response({{"hit", false}});
  const render::VoxelHit& h = pick->hit;
  nlohmann::json body{{"hit", true},
                      {"voxel", {h.voxel.x, h.voxel.y, h.voxel.z}},
                      {"point", {h.point.x, h.point.y, h.point.z}},
                      {"distance", h.distance}};
  if (pick->label) body["label"] = *pick->label;
  if (pick->value) body["value"] = *pick->value;
  return json_response(body);
}

}  // namespace strata::server::detail
