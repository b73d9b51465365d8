// The global-basis fit (ta/global_basis.hpp, paper 2 §4.1): streamed HOOI over a whole volume,
// from DCT or random starting factors. Counters: the fit after the first and the last sweep, the
// sweeps run and the voxels streamed per second (three passes a sweep). Then level 0 of the
// global-basis octree (brick 32, overlap 2): every brick projected on its row-block bases with
// float cores, and the SNR of the bricks' cores rebuilt at rank K against the volume. The
// volume is a generated prisms 128^3 u16, or the file named by STRATA_BENCH_VOLUME.
//   STRATA_BENCH_VOLUME=/usr/share/mricron/templates/ch2better.nii.gz
//     ./build/release/bench/bench_global_basis --benchmark_counters_tabular=true
// (one command line).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <memory>

#include "strata/core/progress.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/core/metrics.hpp"
#include "strata/ta/global_basis.hpp"
#include "strata/tensor/ttm.hpp"

namespace strata {
namespace {

class MemorySource final : public io::VolumeSource {
 public:
  explicit MemorySource(Volume v) : volume_(std::move(v)) {}
  const VolumeInfo& info() const override { return volume_.info(); }
  const std::filesystem::path& path() const override { return path_; }
  Volume read_box(const Box& box) override { return volume_.crop(box); }

 private:
  Volume volume_;
  std::filesystem::path path_ = "bench-volume";
};

std::unique_ptr<io::VolumeSource> bench_source() {
  if (const char* file = std::getenv("STRATA_BENCH_VOLUME")) return io::open_volume(file);
  gen::Params p;
  p.kind = gen::Kind::prisms;
  p.dims = {128, 128, 128};
  p.seed = 1;
  return std::make_unique<MemorySource>(gen::generate(p));
}

// Args: rank, init (0 = DCT, 1 = random), sweeps.
void BM_FitGlobalFactors(benchmark::State& state) {
  const auto source = bench_source();
  ta::GlobalFitOptions o;
  o.rank = int(state.range(0));
  o.init = state.range(1) == 0 ? ta::GlobalInit::dct : ta::GlobalInit::random;
  o.max_sweeps = int(state.range(2));
  o.tolerance = 0;
  ta::GlobalFit fit;
  for (auto _ : state) fit = ta::fit_global_factors(*source, o, silent_progress());
  state.counters["fit_first"] = fit.fit_per_sweep.front();
  state.counters["fit_last"] = fit.fit();
  state.counters["sweeps"] = double(fit.fit_per_sweep.size());
  state.counters["Mvox/s"] = benchmark::Counter(
      double(source->info().dims.voxel_count()) * double(fit.passes) * double(state.iterations()) / 1e6,
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FitGlobalFactors)
    ->ArgNames({"rank", "init", "sweeps"})
    ->Args({16, 0, 1})
    ->Args({16, 1, 1})
    ->Args({16, 0, 4})
    ->Args({16, 1, 4})
    ->Args({32, 0, 4})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Args: fitted rank R, reconstruction rank K. Level 0 only: the volume is read whole.
void BM_GlobalBasisLevel0(benchmark::State& state) {
  const auto source = bench_source();
  const Volume whole = source->read_all().converted(DType::f32);
  ta::GlobalFitOptions o;
  o.rank = int(state.range(0));
  const int k = int(state.range(1));
  const ta::GlobalFit fit = ta::fit_global_factors(*source, o, silent_progress());
  const Extent d = whole.dims();
  const ta::OctreeGeometry geometry(d, {32, 2});
  const ta::GlobalBases bases(fit.factors, geometry);
  Volume rebuilt(d, DType::f32);
  const auto in = whole.view<float>();
  auto out = rebuilt.view<float>();
  for (auto _ : state) {
    const Extent& grid = geometry.level(0).bricks;
    for (std::int64_t bz = 0; bz < grid.z; ++bz)
      for (std::int64_t by = 0; by < grid.y; ++by)
        for (std::int64_t bx = 0; bx < grid.x; ++bx) {
          const Box box = geometry.brick_sample_box(0, bx, by, bz);
          tensor::Tensor3 samples(32, 32, 32);
          for (int z = 0; z < 32; ++z)
            for (int y = 0; y < 32; ++y)
              for (int x = 0; x < 32; ++x)
                samples(x, y, z) = in(std::clamp<std::int64_t>(box.lo.x + x, 0, d.x - 1),
                                      std::clamp<std::int64_t>(box.lo.y + y, 0, d.y - 1),
                                      std::clamp<std::int64_t>(box.lo.z + z, 0, d.z - 1));
          const auto q = bases.brick_bases(0, bx, by, bz);
          const tensor::Tensor3 core = ta::project_brick(samples, q);
          tensor::Tensor3 leading(std::min<std::int64_t>(k, core.dim(1)), std::min<std::int64_t>(k, core.dim(2)),
                                  std::min<std::int64_t>(k, core.dim(3)));
          for (std::int64_t c = 0; c < leading.dim(3); ++c)
            for (std::int64_t b = 0; b < leading.dim(2); ++b)
              for (std::int64_t a = 0; a < leading.dim(1); ++a) leading(a, b, c) = core(a, b, c);
          const tensor::Tensor3 r = tensor::reconstruct(
              leading, tensor::Factors<float>{q[0]->leftCols(leading.dim(1)), q[1]->leftCols(leading.dim(2)),
                                              q[2]->leftCols(leading.dim(3))});
          const Box core_box = geometry.brick_core_box(0, bx, by, bz);
          for (std::int64_t z = core_box.lo.z; z < core_box.hi.z; ++z)
            for (std::int64_t y = core_box.lo.y; y < core_box.hi.y; ++y)
              for (std::int64_t x = core_box.lo.x; x < core_box.hi.x; ++x)
                out(x, y, z) = r(x - box.lo.x, y - box.lo.y, z - box.lo.z);
        }
  }
  const ErrorMetrics m = compare_volumes(whole, rebuilt);
  state.counters["snr_db"] = m.snr_db;
  state.counters["psnr_db"] = m.psnr_db;
  state.counters["global_fit"] = fit.fit();
}
BENCHMARK(BM_GlobalBasisLevel0)
    ->ArgNames({"R", "K"})
    ->Args({16, 16})
    ->Args({32, 16})
    ->Args({32, 32})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace strata

BENCHMARK_MAIN();
