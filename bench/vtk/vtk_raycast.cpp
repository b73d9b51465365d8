// The reference side of the renderer comparison: VTK's CPU ray caster
// (vtkFixedPointVolumeRayCastMapper) orbiting a volume with the same camera path, transfer
// function, sample distance and shading as `strata render --orbit`. Prints one JSON object
// with CPU seconds and wall seconds per frame.
//   vtk_raycast VOLUME --size 1024x768 --orbit 24 --tf ct --step 0.5 --shading on --threads 2
//               [--azimuth 30 --elevation 20 --distance D] [-o first.png] [--frames-dir DIR]
// --distance (world units, 0 = strata's bounding-sphere fit) takes the distance `strata render
// --stats` reports, so both frame a volume alike; --frames-dir writes every frame as
// DIR/frame_NNNN.png (strata's naming) for image-error comparisons.
// The camera and transfer function come from strata's own classes, so both programs agree.
#include <algorithm>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <vtkCamera.h>
#include <vtkColorTransferFunction.h>
#include <vtkFixedPointVolumeRayCastMapper.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkPiecewiseFunction.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkVolume.h>
#include <vtkVolumeProperty.h>
#include <vtkWindowToImageFilter.h>

#include "strata/core/statistics.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/transfer_function.hpp"

namespace {

using namespace strata;

struct Args {
  std::string input, tf = "ct", png, frames_dir;
  int width = 1024, height = 768, frames = 24, threads = 2;
  double step = 0.5, azimuth = 30, elevation = 20, distance = 0;  // strata render's defaults
  bool shading = true;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error("missing value after " + k);
      return argv[++i];
    };
    if (k == "--size") {
      const std::string v = value();
      a.width = std::stoi(v.substr(0, v.find('x')));
      a.height = std::stoi(v.substr(v.find('x') + 1));
    } else if (k == "--orbit") a.frames = std::stoi(value());
    else if (k == "--tf") a.tf = value();
    else if (k == "--step") a.step = std::stod(value());
    else if (k == "--azimuth") a.azimuth = std::stod(value());
    else if (k == "--elevation") a.elevation = std::stod(value());
    else if (k == "--shading") a.shading = value() == "on";
    else if (k == "--threads") a.threads = std::stoi(value());
    else if (k == "--distance") a.distance = std::stod(value());
    else if (k == "--frames-dir") a.frames_dir = value();
    else if (k == "-o") a.png = value();
    else if (a.input.empty()) a.input = k;
    else throw std::runtime_error("unexpected argument " + k);
  }
  if (a.input.empty()) throw std::runtime_error("usage: vtk_raycast VOLUME [options]");
  return a;
}

// VTK's point layout is x fastest like ours; unsigned 8/16-bit stay native (the fixed-point
// mapper's fast paths), everything else becomes float.
vtkNew<vtkImageData> to_image(const Volume& v) {
  vtkNew<vtkImageData> image;
  image->SetDimensions(int(v.dims().x), int(v.dims().y), int(v.dims().z));
  image->SetSpacing(v.spacing().x, v.spacing().y, v.spacing().z);
  // strata voxel i covers [i, i+1): its centre, where VTK puts point i, is i + 0.5.
  image->SetOrigin(0.5 * v.spacing().x, 0.5 * v.spacing().y, 0.5 * v.spacing().z);
  const std::size_t n = std::size_t(v.dims().voxel_count());
  if (v.dtype() == DType::u8 || v.dtype() == DType::u16) {
    image->AllocateScalars(v.dtype() == DType::u8 ? VTK_UNSIGNED_CHAR : VTK_UNSIGNED_SHORT, 1);
    std::memcpy(image->GetScalarPointer(), v.bytes(), n * dtype_size(v.dtype()));
  } else {
    image->AllocateScalars(VTK_FLOAT, 1);
    const Volume f = v.converted(DType::f32);
    std::memcpy(image->GetScalarPointer(), f.bytes(), n * sizeof(float));
  }
  return image;
}

// The strata TF (normalised x over [lo, hi], alpha per one-voxel reference step) as VTK
// functions over data values with the opacity unit distance set to that reference step.
void set_transfer_function(vtkVolumeProperty* p, const render::TransferFunction& tf, double lo, double hi,
                           double unit) {
  vtkNew<vtkColorTransferFunction> color;
  vtkNew<vtkPiecewiseFunction> opacity;
  const render::ValueMapping m = tf.mapping(lo, hi);
  double previous = -1e300;
  for (const render::TfPoint& pt : tf.points()) {
    double v = m.lo + pt.x * (m.hi - m.lo);
    if (v <= previous) v = previous + 1e-6 * (m.hi - m.lo);  // VTK keeps one point per value: steps
    previous = v;
    color->AddRGBPoint(v, pt.rgba[0], pt.rgba[1], pt.rgba[2]);
    opacity->AddPoint(v, pt.rgba[3]);
  }
  p->SetColor(color);
  p->SetScalarOpacity(opacity);
  p->SetScalarOpacityUnitDistance(unit);
}

// The window's current image (RGB, outside the frame timing).
void write_png(vtkRenderWindow* window, const std::string& path) {
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(path.c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
}

}  // namespace

int main(int argc, char** argv) try {
  const Args args = parse(argc, argv);
  const Volume volume = io::read_volume(args.input);
  const VolumeStatistics stats = compute_statistics(volume);
  const double lo = stats.min, hi = stats.max;  // the value range strata stores with a file
  const render::TransferFunction tf = render::TransferFunction::from_argument(args.tf);

  vtkNew<vtkFixedPointVolumeRayCastMapper> mapper;
  mapper->SetInputData(to_image(volume));
  mapper->SetNumberOfThreads(args.threads);
  mapper->SetAutoAdjustSampleDistances(0);
  mapper->SetLockSampleDistanceToInputSpacing(0);
  const Spacing sp = volume.spacing();
  const double unit = std::min({sp.x, sp.y, sp.z});
  mapper->SetSampleDistance(float(args.step * unit));
  mapper->SetInteractiveSampleDistance(float(args.step * unit));
  mapper->SetImageSampleDistance(1.0f);

  vtkNew<vtkVolumeProperty> property;
  set_transfer_function(property, tf, lo, hi, unit);
  property->SetInterpolationTypeToLinear();
  const render::RenderOptions defaults;
  property->SetShade(args.shading ? 1 : 0);
  property->SetAmbient(defaults.light.ambient);
  property->SetDiffuse(defaults.light.diffuse);
  property->SetSpecular(defaults.light.specular);
  property->SetSpecularPower(defaults.light.shininess);
  vtkNew<vtkVolume> actor;
  actor->SetMapper(mapper);
  actor->SetProperty(property);

  vtkNew<vtkRenderer> renderer;
  renderer->AddVolume(actor);
  renderer->SetBackground(0, 0, 0);
  vtkNew<vtkRenderWindow> window;
  window->SetOffScreenRendering(1);
  window->AddRenderer(renderer);
  window->SetSize(args.width, args.height);

  nlohmann::json frames = nlohmann::json::array();
  double cpu_total = 0, wall_total = 0;
  for (int f = 0; f < args.frames; ++f) {
    render::CameraSpec spec;
    spec.width = args.width;
    spec.height = args.height;
    spec.orbit.azimuth_deg = args.azimuth + 360.0 * f / args.frames;  // as strata render --orbit
    spec.orbit.elevation_deg = args.elevation;
    spec.orbit.distance = args.distance;
    const render::Camera cam(spec, volume.dims(), sp);
    vtkCamera* c = renderer->GetActiveCamera();
    c->SetPosition(cam.eye().x, cam.eye().y, cam.eye().z);
    const Vec3 target = cam.eye() + cam.forward();
    c->SetFocalPoint(target.x, target.y, target.z);
    c->SetViewUp(cam.up().x, cam.up().y, cam.up().z);
    c->SetViewAngle(spec.fov_deg);
    renderer->ResetCameraClippingRange();
    const double c0 = cpu_seconds();
    const auto w0 = SteadyClock::now();
    window->Render();
    const double wall = seconds_since(w0);
    const double cpu = cpu_seconds() - c0;
    cpu_total += cpu;
    wall_total += wall;
    frames.push_back({{"frame", f}, {"cpu_s", cpu}, {"wall_s", wall}});
    if (f == 0 && !args.png.empty()) write_png(window, args.png);
    if (!args.frames_dir.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "/frame_%04d.png", f);
      write_png(window, args.frames_dir + name);
    }
  }
  const nlohmann::json out{{"renderer", "vtkFixedPointVolumeRayCastMapper"},
                           {"input", args.input},
                           {"size", {args.width, args.height}},
                           {"frames", args.frames},
                           {"threads", args.threads},
                           {"cpu_s_per_frame", cpu_total / args.frames},
                           {"wall_s_per_frame", wall_total / args.frames},
                           {"per_frame", frames}};
  std::printf("%s\n", out.dump(2).c_str());
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "error: %s\n", e.what());
  return 1;
}
