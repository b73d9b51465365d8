// Generation throughput of the synthetic volumes, slab by slab as generate_to_file runs them.
//   ./build/release/bench/bench_generators --benchmark_format=json
#include <benchmark/benchmark.h>

#include "strata/gen/generators.hpp"

namespace {

void run(benchmark::State& state, strata::gen::Kind kind, strata::Extent dims, std::int64_t count, std::int64_t slab) {
  strata::gen::Params p;
  p.kind = kind;
  p.dims = dims;
  p.seed = 1;
  p.count = count;
  for (auto _ : state) {
    auto g = strata::gen::make_generator(p);
    for (std::int64_t z0 = 0; z0 < dims.z; z0 += slab) benchmark::DoNotOptimize(g->slab(z0, std::min(dims.z, z0 + slab)));
  }
  state.counters["Mvox/s"] =
      benchmark::Counter(double(dims.voxel_count()) * double(state.iterations()) / 1e6, benchmark::Counter::kIsRate);
}

void BM_Prisms256(benchmark::State& s) { run(s, strata::gen::Kind::prisms, {256, 256, 256}, 0, 64); }
void BM_Fibres512x10000(benchmark::State& s) { run(s, strata::gen::Kind::fibres, {512, 512, 512}, 10000, 64); }
void BM_Voronoi256(benchmark::State& s) { run(s, strata::gen::Kind::voronoi, {256, 256, 256}, 64, 64); }
void BM_Prisms1024x1024x512(benchmark::State& s) { run(s, strata::gen::Kind::prisms, {1024, 1024, 512}, 0, 16); }

}  // namespace

BENCHMARK(BM_Prisms256)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Fibres512x10000)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_Voronoi256)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Prisms1024x1024x512)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK_MAIN();
