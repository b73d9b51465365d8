// Mixture Graph encoding on real and synthetic label volumes: label map + histogram mipmap +
// greedy factorisation (the encode), then schedule, palette propagation (RGBA) and the
// mixture lookup, with the round-trip max l1 error against the exact mipmap.
//   ./build/release/bench/bench_mixture --benchmark_counters_tabular=true
//   ./build/release/bench/bench_mixture --benchmark_filter=medulla
// Real data is read from ../shared/data (override with STRATA_SHARED_DATA=<dir>); missing
// files are reported as skipped. Thread count: strata::thread_count() (OMP_NUM_THREADS).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "strata/core/stopwatch.hpp"
#include "strata/core/threads.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/factorize.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/palette.hpp"
#include "strata/mixture/schedule.hpp"

namespace {

using namespace strata;
using namespace strata::mixture;
using Clock = std::chrono::steady_clock;

std::filesystem::path data_dir() {
  if (const char* d = std::getenv("STRATA_SHARED_DATA")) return d;
  return std::filesystem::path(__FILE__).parent_path() / ".." / ".." / "shared" / "data";
}

struct Input {
  std::string file;  // under data_dir(), or empty for a synthetic volume
  gen::Params params;
};

Volume load(const Input& in) {
  if (in.file.empty()) return gen::generate(in.params);
  return io::read_volume(data_dir() / in.file);
}

void run(benchmark::State& state, const Input& in, FactorOptions options) {
  if (!in.file.empty() && !std::filesystem::exists(data_dir() / in.file)) {
    state.SkipWithError(("missing " + (data_dir() / in.file).string()).c_str());
    return;
  }
  const Volume labels = load(in);
  for (auto _ : state) {
    const auto t0 = Clock::now();
    HistogramMipmap h = HistogramMipmap::from_labels(labels);
    const double t_mipmap = seconds_since(t0);
    const MipmapStats ms = h.stats();
    const auto t1 = Clock::now();
    const Factorization f = factorize(std::move(h), options);  // consumes the id arrays, keeps the table
    const double t_factor = seconds_since(t1);
    const double t_encode = seconds_since(t0);

    const auto t2 = Clock::now();
    const Schedule s = make_schedule(f.graph);
    const double t_schedule = seconds_since(t2);
    std::vector<float> rgba(std::size_t(h.num_sources()) * 4);
    for (std::size_t i = 0; i < rgba.size(); ++i) rgba[i] = float((i * 2654435761u) % 1000) / 1000.0f;
    std::vector<float> palette(f.graph.node_count() * 4);
    const auto t3 = Clock::now();
    propagate_palette(f.graph, s, rgba, 4, palette);
    const double t_palette = seconds_since(t3);
    const auto t4 = Clock::now();
    const MixtureLookup lut = MixtureLookup::build(f.graph, s);
    const double t_lookup = seconds_since(t4);
    const ErrorReport e = measure_error(h, f, lut);

    state.counters["sources"] = h.num_sources();
    state.counters["voxels_M"] = double(ms.voxels) / 1e6;
    state.counters["distinct"] = double(ms.distinct_mixtures);
    state.counters["nnz_per_voxel"] = ms.nnz_per_voxel;
    state.counters["input_pairs"] = double(ms.input_pairs);
    state.counters["nodes"] = double(f.stats.nodes);
    state.counters["depth"] = f.stats.depth;
    state.counters["steps"] = double(f.stats.steps);
    state.counters["reused"] = double(f.stats.reused);
    state.counters["dense"] = double(f.stats.dense_mixtures);
    state.counters["max_l1"] = e.max_l1;
    state.counters["mean_l1"] = e.mean_l1;
    state.counters["t_mipmap_s"] = t_mipmap;
    state.counters["t_factor_s"] = t_factor;
    state.counters["t_encode_s"] = t_encode;
    state.counters["t_schedule_ms"] = t_schedule * 1e3;
    state.counters["t_palette_ms"] = t_palette * 1e3;
    state.counters["t_lookup_ms"] = t_lookup * 1e3;
    state.counters["lookup_nnz"] = double(lut.total_nnz());
    state.counters["threads"] = thread_count();
    benchmark::DoNotOptimize(palette.data());
  }
}

FactorOptions opts(PairScore score = PairScore::reduction, WeightBins bins = WeightBins::symmetric,
                   std::uint32_t dense = 8, std::uint32_t tau = 3) {
  FactorOptions o;
  o.score = score;
  o.bins = bins;
  o.dense_threshold = dense;
  o.tau = tau;
  return o;
}

gen::Params synthetic(gen::Kind kind, Extent dims, std::int64_t count) {
  gen::Params p;
  p.kind = kind;
  p.dims = dims;
  p.seed = 1;
  p.count = count;
  return p;
}

const Input kGala{"gala_fibsem_test_gt.nrrd", {}};
const Input kMedulla{"fibsem_medulla_250_ws.nrrd", {}};
const Input kMedullaGt{"fibsem_medulla_250_gt.nrrd", {}};
const Input kFibres512{"", synthetic(gen::Kind::fibres, {512, 512, 512}, 10000)};
const Input kVoronoi256{"", synthetic(gen::Kind::voronoi, {256, 256, 256}, 2000)};

void BM_Gala(benchmark::State& s) { run(s, kGala, opts()); }
void BM_GalaUniformBins(benchmark::State& s) { run(s, kGala, opts(PairScore::reduction, WeightBins::uniform)); }
void BM_Medulla250Ws(benchmark::State& s) { run(s, kMedulla, opts()); }
void BM_Medulla250WsOccurrence(benchmark::State& s) { run(s, kMedulla, opts(PairScore::occurrence)); }
void BM_Medulla250WsReuse(benchmark::State& s) { run(s, kMedulla, opts(PairScore::reuse)); }
void BM_Medulla250WsUniformBins(benchmark::State& s) { run(s, kMedulla, opts(PairScore::reduction, WeightBins::uniform)); }
void BM_Medulla250WsDense64(benchmark::State& s) { run(s, kMedulla, opts(PairScore::reduction, WeightBins::symmetric, 64)); }
void BM_Medulla250Gt(benchmark::State& s) { run(s, kMedullaGt, opts()); }
void BM_Voronoi256x2000(benchmark::State& s) { run(s, kVoronoi256, opts()); }
void BM_Fibres512x10000(benchmark::State& s) { run(s, kFibres512, opts()); }

// Palette propagation alone (a transfer-function change), medulla ws graph, range(0) threads.
void BM_PaletteThreads(benchmark::State& state) {
  if (!std::filesystem::exists(data_dir() / kMedulla.file)) {
    state.SkipWithError("missing fibsem_medulla_250_ws.nrrd");
    return;
  }
  static const Factorization f = factorize(HistogramMipmap::from_labels(load(kMedulla)), opts());
  static const Schedule s = make_schedule(f.graph);
  std::vector<float> rgba(std::size_t(f.graph.num_sources) * 4);
  for (std::size_t i = 0; i < rgba.size(); ++i) rgba[i] = float((i * 2654435761u) % 1000) / 1000.0f;
  std::vector<float> palette(f.graph.node_count() * 4);
  const int previous = thread_count();
  set_thread_count(int(state.range(0)));
  for (auto _ : state) {
    propagate_palette(f.graph, s, rgba, 4, palette);
    benchmark::DoNotOptimize(palette.data());
  }
  set_thread_count(previous);
  state.counters["threads"] = double(state.range(0));
  state.counters["nodes"] = double(f.graph.node_count());
  state.counters["nodes_per_s"] =
      benchmark::Counter(double(f.graph.node_count()), benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_PaletteThreads)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
#define MIX_BENCH(f) BENCHMARK(f)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1)
MIX_BENCH(BM_Gala);
MIX_BENCH(BM_GalaUniformBins);
MIX_BENCH(BM_Medulla250Ws);
MIX_BENCH(BM_Medulla250WsOccurrence);
MIX_BENCH(BM_Medulla250WsReuse);
MIX_BENCH(BM_Medulla250WsUniformBins);
MIX_BENCH(BM_Medulla250WsDense64);
MIX_BENCH(BM_Medulla250Gt);
MIX_BENCH(BM_Voronoi256x2000);
MIX_BENCH(BM_Fibres512x10000);
BENCHMARK_MAIN();
