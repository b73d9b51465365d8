// The global-basis fit (ta/global_basis.hpp, paper 2 §4.1): streamed HOOI over a whole volume,
// from DCT or random starting factors. Counters: the fit after the first and the last sweep, the
// sweeps run and the voxels streamed per second (three passes a sweep). The volume is a
// generated prisms 128^3 u16, or the file named by STRATA_BENCH_VOLUME.
//   STRATA_BENCH_VOLUME=/usr/share/mricron/templates/ch2better.nii.gz \
//     ./build/release/bench/bench_global_basis --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <memory>

#include "strata/core/progress.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/global_basis.hpp"

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

}  // namespace
}  // namespace strata

BENCHMARK_MAIN();
