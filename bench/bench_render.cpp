// The scalar ray caster on an in-memory prisms volume cut into 32^3 bricks (no decoding): one
// 512x512 frame per iteration, per transfer-function preset, with and without shading.
//   ./build/release/bench/bench_render --benchmark_counters_tabular=true
// Counters: samples per frame and samples/s. Threads: strata::thread_count() (OMP_NUM_THREADS).
#include <benchmark/benchmark.h>

#include "strata/gen/generators.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/transfer_function.hpp"
#include "strata/ta/octree.hpp"

namespace {

using namespace strata;

struct Scene {
  Volume volume;
  ta::OctreeGeometry geometry;
  lod::FrameBricks bricks;
  double lo = 0, hi = 0;
};

const Scene& scene() {
  static const Scene* s = [] {
    gen::Params p;
    p.kind = gen::Kind::prisms;
    p.dims = {128, 128, 128};
    Volume v = gen::generate(p);
    ta::OctreeGeometry g(v.dims(), ta::BrickLayout{});
    auto* out = new Scene{std::move(v), g, {}, 0, 65535};
    out->bricks = render::bricks_from_volume(out->volume, out->geometry);
    return out;
  }();
  return *s;
}

void BM_Frame512(benchmark::State& state, const char* preset, bool shading) {
  const Scene& s = scene();
  render::RenderOptions o;
  o.shading = shading;
  render::RayCaster caster(render::TransferFunction::preset(preset), o);
  render::CameraSpec spec;
  spec.width = spec.height = 512;
  const render::Camera camera(spec, s.volume.dims(), s.volume.spacing());
  const render::FrameInput frame{&s.bricks, &s.geometry, s.volume.spacing(), s.lo, s.hi, nullptr};
  render::RenderStats stats;
  caster.render(camera, frame, &stats);  // builds the classification tables and cell flags
  for (auto _ : state) benchmark::DoNotOptimize(caster.render(camera, frame, &stats));
  state.counters["samples"] = double(stats.samples);
  state.counters["samples_per_s"] =
      benchmark::Counter(double(stats.samples), benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK_CAPTURE(BM_Frame512, ct, "ct", false)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Frame512, ct_shaded, "ct", true)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Frame512, mri, "mri", false)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Frame512, mri_shaded, "mri", true)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
