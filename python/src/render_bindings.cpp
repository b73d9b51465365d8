// strata.Renderer: frames of a .strata file (either codec) or a plain volume file, ray cast on
// the CPU through render::RenderSession, as `strata render` draws them, returned as (h, w, 4)
// uint8 arrays. strata.render (python/strata/__init__.py) is one frame of a fresh Renderer.
#include <array>
#include <mutex>
#include <string>

#include <fmt/format.h>

#include "bindings.hpp"
#include "files.hpp"
#include "strata/core/error.hpp"
#include "strata/render/render_session.hpp"

namespace strata::python {

namespace {

struct Renderer {
  std::unique_ptr<render::RenderSession> session;  // null once closed
  std::mutex mutex;                                // one frame at a time (per-session caches)
  nlohmann::json stats;                            // of the last frame

  // The open session; throws py::value_error once closed. Call with `mutex` held when the GIL
  // is released (close() takes it too).
  render::RenderSession& get() {
    if (!session) throw py::value_error("the renderer is closed");
    return *session;
  }
};

// A source given as a path, or as a file strata.open returned (its path and member).
std::pair<std::filesystem::path, std::optional<std::int64_t>> render_source(py::handle source,
                                                                             std::optional<std::int64_t> volume) {
  for (const char* type : {"ScalarFile", "LabelFile"})
    if (py::isinstance(source, py::module_::import("strata._strata").attr(type))) {
      const py::object member = source.attr("volume");
      if (volume && !member.is_none() && py::cast<std::int64_t>(member) != *volume)
        throw py::value_error("volume: the file was opened as another member of its volume set");
      return {path_from_python(source.attr("path"), "source"),
              member.is_none() ? volume : std::optional<std::int64_t>(py::cast<std::int64_t>(member))};
    }
  return {path_from_python(source, "source"), volume};
}

render::LabelColorMap label_colors(py::handle colors) {
  if (py::isinstance<py::dict>(colors)) return render::LabelColorMap::from_json(json_from_python(colors, "colors"), "colors");
  return render::LabelColorMap::load(path_from_python(colors, "colors"));
}

std::shared_ptr<const render::TransferFunction> transfer_function(py::handle tf) {
  if (tf.is_none()) return nullptr;  // the session's default, the "ct" preset
  if (py::isinstance<py::dict>(tf))
    return std::make_shared<const render::TransferFunction>(
        render::TransferFunction::from_json(json_from_python(tf, "tf"), "tf"));
  return std::make_shared<const render::TransferFunction>(
      render::TransferFunction::from_argument(path_from_python(tf, "tf").string()));
}

render::LabelLightingChoice lighting_choice(const std::string& name) {
  if (name == "auto") return render::LabelLightingChoice::automatic;
  if (name == "gradient") return render::LabelLightingChoice::gradient;
  if (name == "gradient-ao") return render::LabelLightingChoice::gradient_occlusion;
  if (name == "normals") return render::LabelLightingChoice::normals;
  throw py::value_error("lighting: expected auto, gradient, gradient-ao or normals, got '" + name + "'");
}

py::array image_array(render::Image image) {
  static_assert(sizeof(render::Rgba8) == 4, "pixels are packed RGBA bytes");
  const py::ssize_t w = image.width(), h = image.height();
  auto* owner = new render::Image(std::move(image));
  py::capsule base(owner, [](void* p) { delete static_cast<render::Image*>(p); });
  return py::array_t<std::uint8_t>({h, w, py::ssize_t(4)}, {w * 4, py::ssize_t(4), py::ssize_t(1)},
                                   reinterpret_cast<const std::uint8_t*>(owner->pixels().data()), base);
}

}  // namespace

void register_render(py::module_& m) {
  const render::SessionOptions session_defaults;
  const render::FrameSettings frame_defaults;
  py::class_<Renderer>(m, "Renderer", R"(A volume opened for rendering: frames ray cast on the CPU as
`strata render` draws them. Keeps its brick caches between frames, so an orbit or a rank sweep
reads and decodes each brick once.)")
      .def(py::init([](py::handle source, std::optional<std::int64_t> volume, std::array<float, 3> background,
                       std::uint64_t cache_bytes, std::int64_t max_bricks, py::handle colors) {
             const auto [path, member] = render_source(source, volume);
             render::SessionOptions options;
             options.background = {background[0], background[1], background[2], 1.0f};
             options.cache_bytes = cache_bytes;
             options.max_bricks = max_bricks;
             options.volume = member;
             render::validate(options);
             auto r = std::make_unique<Renderer>();
             std::optional<render::LabelColorMap> map;
             if (!colors.is_none()) map = label_colors(colors);
             py::gil_scoped_release release;
             r->session = std::make_unique<render::RenderSession>(path, options);
             if (map && r->session->kind() == render::DatasetKind::labels) r->session->set_label_colors(std::move(*map));
             return r;
           }),
           py::arg("source"), py::kw_only(), py::arg("volume") = py::none(),
           py::arg("background") = std::array<float, 3>{session_defaults.background[0], session_defaults.background[1],
                                                        session_defaults.background[2]},
           py::arg("cache_bytes") = session_defaults.cache_bytes, py::arg("max_bricks") = session_defaults.max_bricks,
           py::arg("colors") = py::none(),
           R"(source: a .strata file (path or strata.open's file) or a raw/NRRD/NIfTI/TIFF volume (loaded
whole). background=(r, g, b) in [0, 1]; cache_bytes the brick cache budget; colors (label files):
a colour map dict {"default": "hash" | [r, g, b, a], "labels": {"17": [1, 0, 0, 1]}} or its JSON
file.)")
      .def_property_readonly("kind", [](Renderer& r) { return std::string(render::dataset_kind_name(r.get().kind())); })
      .def_property_readonly("shape", [](Renderer& r) { return shape_of(r.get().dims()); })
      .def_property_readonly("stats",
                             [](Renderer& r) {
                               nlohmann::json stats;
                               {
                                 py::gil_scoped_release release;  // a frame may hold the lock
                                 std::lock_guard lock(r.mutex);
                                 stats = r.stats;
                               }
                               return json_to_python(stats);
                             },
                             "Figures of the last frame (selection, load, render, frame_ms, ...).")
      .def(
          "set_colors",
          [](Renderer& r, py::handle colors) {
            render::LabelColorMap map = label_colors(colors);
            py::gil_scoped_release release;
            std::lock_guard lock(r.mutex);
            r.get().set_label_colors(std::move(map));
          },
          py::arg("colors"), "Label files: new label colours (a colour map dict or JSON file) for later frames.")
      .def(
          "frame",
          [](Renderer& r, std::array<int, 2> size, double azimuth, double elevation, double distance, double fov,
             bool ortho, py::handle tf, int rank, double lod, double feature_scale, double step, bool shading,
             const std::string& lighting, double lod_bias) {
            render::FrameSettings f;
            f.camera.width = size[0];
            f.camera.height = size[1];
            f.camera.orbit.azimuth_deg = azimuth;
            f.camera.orbit.elevation_deg = elevation;
            f.camera.orbit.distance = distance;
            f.camera.fov_deg = fov;
            f.camera.projection = ortho ? render::Projection::orthographic : render::Projection::perspective;
            f.rank = rank;
            f.lod = lod;
            f.feature_scale = feature_scale;
            f.step = step;
            f.shading = shading;
            f.label_lighting = lighting_choice(lighting);
            f.lod_bias = lod_bias;
            f.quality = render::FrameQuality::exact;
            render::validate(f);  // before the transfer function file is read
            f.tf = transfer_function(tf);
            render::Image image;
            {
              py::gil_scoped_release release;
              std::lock_guard lock(r.mutex);
              nlohmann::json stats;
              image = r.get().frame(f, stats);
              r.stats = std::move(stats);
            }
            return image_array(std::move(image));
          },
          py::kw_only(),
          py::arg("size") = std::array<int, 2>{frame_defaults.camera.width, frame_defaults.camera.height},
          py::arg("azimuth") = frame_defaults.camera.orbit.azimuth_deg,
          py::arg("elevation") = frame_defaults.camera.orbit.elevation_deg,
          py::arg("distance") = frame_defaults.camera.orbit.distance, py::arg("fov") = frame_defaults.camera.fov_deg,
          py::arg("ortho") = false, py::arg("tf") = "ct", py::arg("rank") = frame_defaults.rank,
          py::arg("lod") = frame_defaults.lod, py::arg("feature_scale") = frame_defaults.feature_scale,
          py::arg("step") = frame_defaults.step, py::arg("shading") = frame_defaults.shading,
          py::arg("lighting") = "auto", py::arg("lod_bias") = frame_defaults.lod_bias,
          R"(One frame, complete (every brick of the level-of-detail cut), as a (height, width, 4) uint8
RGBA array, row 0 at the top. size=(width, height); azimuth/elevation in degrees, distance in world
units (0 frames the volume); tf: a preset (grayscale, ct, bone, mri, fire), a JSON file or a dict
{"range": [lo, hi], "points": [{"x": .., "rgba": [..]}, ..]}; rank: reconstruction rank (0 = stored);
lod, feature_scale, step, shading, lighting, lod_bias as `strata render` --lod, --feature-scale,
--step, --shading, --lighting, --lod-bias.)")
      .def("close", [](Renderer& r) {
        py::gil_scoped_release release;
        std::lock_guard lock(r.mutex);
        r.session.reset();
      })
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](Renderer& r, py::args) {
        py::gil_scoped_release release;
        std::lock_guard lock(r.mutex);
        r.session.reset();
      });
}

}  // namespace strata::python
