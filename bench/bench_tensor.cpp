// Tensor benchmarks: brick reconstruction (the renderer's hot path), HOSVD and HOOI per brick
// (the compressor's), the eigen-solver of the decompositions per instruction set, and a
// single-core FMA peak measurement that puts the reconstruction's FLOP rate in context.
//   ./bench_tensor --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <ctime>
#include <random>

#include <Eigen/Eigenvalues>

// The decomposition kernels are private to src/tensor; the benchmark reaches them directly.
#include "../src/tensor/decompose_kernel.hpp"
#include "strata/core/isa.hpp"
#include "strata/quant/brick.hpp"
#include "strata/tensor/reconstruct.hpp"
#include "strata/tensor/ttm.hpp"
#include "strata/tensor/tucker.hpp"

namespace strata::tensor {
namespace {

constexpr int kBrick = 32;  // B, paper §3
constexpr int kRank = 16;   // R = B / 2

// A brick with the character of a scan: smooth blob, oblique wave, fine noise.
Tensor3 synthetic_brick(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  Tensor3 t(kBrick, kBrick, kBrick);
  for (int k = 0; k < kBrick; ++k)
    for (int j = 0; j < kBrick; ++j)
      for (int i = 0; i < kBrick; ++i) {
        const double r2 = (i - 12.0) * (i - 12.0) + (j - 15.0) * (j - 15.0) + (k - 18.0) * (k - 18.0);
        t(i, j, k) = float(100.0 + 80.0 * std::exp(-r2 / 90.0) + 20.0 * std::sin(0.4 * i + 0.3 * j - 0.2 * k)) +
                     noise(rng);
      }
  return t;
}

// ---- FMA peak -------------------------------------------------------------------------------
// Independent accumulator chains hide the FMA latency (4 cycles, 2 ports => >= 8 chains).
template <int VW>
struct VecOf {
  typedef float type __attribute__((vector_size(VW * sizeof(float))));
};

// Twelve named accumulators (an array would live on the stack); each update is opaque to the
// optimiser through an empty asm, so no iteration can be folded away.
template <int VW>
[[gnu::always_inline]] inline float fma_chains(std::int64_t iterations) {
  using V = typename VecOf<VW>::type;
  const V scale = V{} + 0.999999f, shift = V{} + 1e-6f;
  V a0 = V{} + 0.f, a1 = V{} + 1.f, a2 = V{} + 2.f, a3 = V{} + 3.f, a4 = V{} + 4.f, a5 = V{} + 5.f;
  V a6 = V{} + 6.f, a7 = V{} + 7.f, a8 = V{} + 8.f, a9 = V{} + 9.f, a10 = V{} + 10.f, a11 = V{} + 11.f;
#define STRATA_FMA_STEP(a) \
  a = a * scale + shift;   \
  asm volatile("" : "+v"(a));
  for (std::int64_t i = 0; i < iterations; ++i) {
    STRATA_FMA_STEP(a0) STRATA_FMA_STEP(a1) STRATA_FMA_STEP(a2) STRATA_FMA_STEP(a3)
    STRATA_FMA_STEP(a4) STRATA_FMA_STEP(a5) STRATA_FMA_STEP(a6) STRATA_FMA_STEP(a7)
    STRATA_FMA_STEP(a8) STRATA_FMA_STEP(a9) STRATA_FMA_STEP(a10) STRATA_FMA_STEP(a11)
  }
#undef STRATA_FMA_STEP
  const V total = a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7 + a8 + a9 + a10 + a11;
  float sum = 0;
  for (int l = 0; l < VW; ++l) sum += total[l];
  return sum;
}

STRATA_TARGET_AVX512 float fma_avx512(std::int64_t n) { return fma_chains<16>(n); }
STRATA_TARGET_AVX2 float fma_avx2(std::int64_t n) { return fma_chains<8>(n); }
float fma_sse(std::int64_t n) { return fma_chains<4>(n); }

// FLOPs of one fma_chains iteration for the widest vectors this CPU has (FMA = 2 FLOPs).
struct FmaProbe {
  float (*run)(std::int64_t);
  double flops_per_iteration;
  const char* isa;
};

FmaProbe fma_probe() {
  if (active_isa() >= Isa::avx512) return {fma_avx512, 12 * 16 * 2, "avx512"};
  if (active_isa() >= Isa::avx2) return {fma_avx2, 12 * 8 * 2, "avx2"};
  return {fma_sse, 12 * 4 * 2, "sse (mul+add)"};
}

void BM_FmaPeak(benchmark::State& state) {
  const FmaProbe probe = fma_probe();
  constexpr std::int64_t kIterations = 1 << 20;
  for (auto _ : state) benchmark::DoNotOptimize(probe.run(kIterations));
  state.counters["flops"] =
      benchmark::Counter(probe.flops_per_iteration * kIterations * double(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(probe.isa);
}
BENCHMARK(BM_FmaPeak)->Unit(benchmark::kMillisecond);

double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Single-core peak in FLOP/s, measured once, for the reconstruction's `peak_fraction` counter.
double measured_peak_flops() {
  static const double peak = [] {
    const FmaProbe probe = fma_probe();
    constexpr std::int64_t kIterations = 1 << 22;
    probe.run(kIterations / 8);  // warm up (frequency ramp)
    // Thread CPU time, like the benchmarks' rates, so other load on the machine cancels out.
    double best = 0;
    for (int rep = 0; rep < 5; ++rep) {
      const double t0 = thread_cpu_seconds();
      benchmark::DoNotOptimize(probe.run(kIterations));
      best = std::max(best, probe.flops_per_iteration * kIterations / (thread_cpu_seconds() - t0));
    }
    return best;
  }();
  return peak;
}

// ---- Reconstruction -------------------------------------------------------------------------
// FLOPs of the three products for a B^3 brick at leading rank K: 2 (B K^3 + B^2 K^2 + B^3 K).
double reconstruction_flops(double b, double k) { return 2 * (b * k * k * k + b * b * k * k + b * b * b * k); }

void report_reconstruction(benchmark::State& state, int k) {
  const double bricks = double(state.iterations());
  const double voxels = bricks * kBrick * kBrick * kBrick;
  state.counters["voxels/s"] = benchmark::Counter(voxels, benchmark::Counter::kIsRate);
  state.counters["flops"] = benchmark::Counter(bricks * reconstruction_flops(kBrick, k), benchmark::Counter::kIsRate);
  // FLOPs / peak, turned into a rate by the framework: the achieved fraction of single-core peak.
  state.counters["peak_fraction"] = benchmark::Counter(bricks * reconstruction_flops(kBrick, k) / measured_peak_flops(),
                                                       benchmark::Counter::kIsRate);
}

// Args: leading rank K, instruction-set level (strata::Isa: 0 generic, 1 sse4.2, 2 avx2, 3 avx512).
void BM_Reconstruct(benchmark::State& state) {
  const int k = int(state.range(0));
  const auto isa = Isa(state.range(1));
  if (!isa_supported(isa)) {
    state.SkipWithError("ISA not supported on this CPU");
    return;
  }
  const ScopedIsaLimit limit(isa);
  const Tucker model = hosvd(synthetic_brick(1), {kRank, kRank, kRank});
  const TuckerView view = view_of(model);
  BrickReconstructor rec;
  std::vector<float> out(kBrick * kBrick * kBrick);
  measured_peak_flops();
  for (auto _ : state) {
    rec.reconstruct(view, {k, k, k}, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  report_reconstruction(state, k);
  state.SetLabel(std::string(isa_name(isa)));
}
BENCHMARK(BM_Reconstruct)
    ->ArgNames({"K", "isa"})
    ->ArgsProduct({{16, 8}, {int(Isa::generic), int(Isa::avx2), int(Isa::avx512)}});

// The same three products as Eigen GEMMs on reshaped views of preallocated buffers (the
// alternative the hand-tuned kernel has to beat). Eigen's code path is fixed at compile time, so
// in the portable build this is SSE2.
void BM_ReconstructEigen(benchmark::State& state) {
  const int k = int(state.range(0));
  const Tucker full = hosvd(synthetic_brick(1), {kRank, kRank, kRank});
  const Tucker model = truncate(full, {k, k, k});
  using Map = Eigen::Map<Matrix<float>>;
  using ConstMap = Eigen::Map<const Matrix<float>>;
  std::vector<float> t1(kBrick * k * k), t2(kBrick * kBrick * k), out(kBrick * kBrick * kBrick);
  const auto& [u1, u2, u3] = model.factors;
  for (auto _ : state) {
    Map(t1.data(), kBrick, k * k).noalias() = u1 * ConstMap(model.core.data(), k, k * k);
    for (int r3 = 0; r3 < k; ++r3)
      Map(t2.data() + r3 * kBrick * kBrick, kBrick, kBrick).noalias() =
          ConstMap(t1.data() + r3 * kBrick * k, kBrick, k) * u2.transpose();
    Map(out.data(), kBrick * kBrick, kBrick).noalias() = ConstMap(t2.data(), kBrick * kBrick, k) * u3.transpose();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  report_reconstruction(state, k);
}
BENCHMARK(BM_ReconstructEigen)->ArgName("K")->Arg(16)->Arg(8);

// Eq. A.5, one voxel at a time: O(R^3) per voxel, the baseline the TTM order removes.
void BM_ReconstructVoxelwise(benchmark::State& state) {
  const Tucker model = hosvd(synthetic_brick(1), {kRank, kRank, kRank});
  for (auto _ : state) benchmark::DoNotOptimize(reconstruct_voxel(model, 3, 5, 7));
  state.counters["voxels/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ReconstructVoxelwise);

// ---- Decomposition --------------------------------------------------------------------------
// Arg 0: the scan-like synthetic brick; arg 1: uniform noise, the worst case for HOOI (slow
// convergence, many sweeps).
Tensor3 decomposition_input(std::int64_t kind) {
  if (kind == 0) return synthetic_brick(2);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> dist(0.0f, 1.0f);
  Tensor3 t(kBrick, kBrick, kBrick);
  for (float& v : t.values()) v = dist(rng);
  return t;
}

void BM_Hosvd(benchmark::State& state) {
  const Tensor3 brick = decomposition_input(state.range(0));
  double fit = 0;
  for (auto _ : state) fit = hosvd(brick, {kRank, kRank, kRank}).fit;
  state.counters["bricks/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["fit"] = fit;
}
BENCHMARK(BM_Hosvd)->ArgName("noise")->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// Default options (tolerance 1e-5 on the fit, at most 50 sweeps).
void BM_Hooi(benchmark::State& state) {
  const Tensor3 brick = decomposition_input(state.range(0));
  Tucker t;
  for (auto _ : state) t = hooi(brick, {kRank, kRank, kRank});
  state.counters["bricks/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["fit"] = t.fit;
  state.counters["sweeps"] = t.iterations;
}
BENCHMARK(BM_Hooi)->ArgName("noise")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The compressor's settings (brick_codec.hpp): one sweep after the initialisation, tolerance 1e-4.
void BM_HooiOneSweep(benchmark::State& state) {
  const Tensor3 brick = decomposition_input(state.range(0));
  Tucker t;
  for (auto _ : state) t = hooi(brick, {kRank, kRank, kRank}, HooiOptions{1e-4, 1, true});
  state.counters["bricks/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["fit"] = t.fit;
}
BENCHMARK(BM_HooiOneSweep)->ArgName("noise")->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// ---- Eigen-decomposition of a brick's Gram matrix ---------------------------------------------
// The decompositions' inner loop: the R leading eigenvectors of the B x B Gram matrix of a mode
// unfolding, by the kernel of each instruction set (bisection + twisted factorisations, QL
// fallback) and, for reference, by Eigen's SelfAdjointEigenSolver (all eigenpairs).
Matrix<double> brick_gram(int n) {
  const Tensor3 brick = decomposition_input(1);
  Matrix<double> g = gram(brick, 1);
  return g.topLeftCorner(n, n);
}

// Args: instruction-set level (strata::Isa), n (R = n / 2).
void BM_LeadingEigenvectors(benchmark::State& state) {
  const auto isa = Isa(state.range(0));
  if (!isa_supported(isa)) {
    state.SkipWithError("ISA not supported by this CPU");
    return;
  }
  const detail::DecomposeKernels& k = detail::decompose_kernels(isa);
  const int n = int(state.range(1)), r = n / 2;
  const Matrix<double> g = brick_gram(n);
  Matrix<double> a(n, n), u(n, r);
  std::vector<double> work(std::size_t(detail::leading_eigen_work(n)));
  for (auto _ : state) {
    a = g;
    benchmark::DoNotOptimize(k.leading_eigen(a.data(), n, r, u.data(), work.data()));
  }
  state.SetLabel(std::string(isa_name(isa)));
}
BENCHMARK(BM_LeadingEigenvectors)
    ->ArgNames({"isa", "n"})
    ->ArgsProduct({{int(Isa::generic), int(Isa::avx2), int(Isa::avx512)}, {32, 16}})->Unit(benchmark::kMicrosecond);

void BM_EigenSelfAdjointSolver(benchmark::State& state) {
  const int n = int(state.range(0));
  const Matrix<double> g = brick_gram(n);
  Eigen::SelfAdjointEigenSolver<Matrix<double>> solver(n);
  for (auto _ : state) {
    solver.compute(g);
    benchmark::DoNotOptimize(solver.eigenvectors().data());
  }
}
BENCHMARK(BM_EigenSelfAdjointSolver)->ArgName("n")->Arg(32)->Arg(16)->Unit(benchmark::kMicrosecond);

// ---- Gram matrices of a brick core's unfoldings -------------------------------------------------
// The encoder's overlap-row fit takes C_(n) C_(n)^T of a 28^3 block-DCT core in every mode, once
// per coded brick: from the float core (gram) or exactly from its integer codes (integer_gram).
// Args: mode (1-3), kernel (0 = gram of floats, 1 = integer_gram of the codes).
void BM_CoreGram(benchmark::State& state) {
  const int mode = int(state.range(0));
  const bool integer = state.range(1) != 0;
  Tensor3 core(28, 28, 28);
  std::vector<std::int32_t> codes(std::size_t(core.size()));
  std::mt19937 rng(7);
  std::geometric_distribution<int> magnitude(0.3);
  for (std::size_t i = 0; i < codes.size(); ++i) {
    codes[i] = (rng() & 1 ? 1 : -1) * magnitude(rng);
    core.values()[i] = float(codes[i]) * 0.5f;
  }
  for (auto _ : state) {
    if (integer) benchmark::DoNotOptimize(integer_gram(codes, core.dims(), mode)->data());
    else benchmark::DoNotOptimize(gram(core, mode).data());
  }
  state.SetLabel(integer ? "integer codes" : "float core");
}
BENCHMARK(BM_CoreGram)->ArgNames({"mode", "integer"})->ArgsProduct({{1, 2, 3}, {0, 1}})->Unit(benchmark::kMicrosecond);

// ---- Decoding quantized bricks --------------------------------------------------------------
const char* const kSchemes[] = {"u16,b8log+", "u16,b8log", "u16,b12log+", "u16,b16log", "u16,b8mu+",
                                "u8,b8lin",   "u16,b16lin", "f32"};

// Bytes -> dequantized core and factors (leading K) -> reconstructed voxels: the loader's work
// per brick. Args: scheme index into kSchemes, K.
void BM_DecodeBrick(benchmark::State& state) {
  const quant::QuantScheme scheme = quant::QuantScheme::parse(kSchemes[state.range(0)]);
  const int k = int(state.range(1));
  const Tucker model = hooi(synthetic_brick(3), {kRank, kRank, kRank});
  const std::vector<std::byte> bytes = quant::serialize(quant::quantize(model, scheme), scheme);
  quant::DequantizedModel decoded;
  BrickReconstructor rec;
  std::vector<float> out(kBrick * kBrick * kBrick);
  for (auto _ : state) {
    quant::dequantize(quant::BrickView(bytes, scheme), {k, k, k}, decoded);
    rec.reconstruct(decoded.view(), out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.counters["voxels/s"] =
      benchmark::Counter(double(state.iterations()) * kBrick * kBrick * kBrick, benchmark::Counter::kIsRate);
  state.SetLabel(kSchemes[state.range(0)]);
}
BENCHMARK(BM_DecodeBrick)->ArgNames({"scheme", "K"})->ArgsProduct({{0, 3, 4, 7}, {16, 8}});

// Dequantization alone (core + factors, K = R): how much the codes add to reconstruction.
void BM_Dequantize(benchmark::State& state) {
  const quant::QuantScheme scheme = quant::QuantScheme::parse(kSchemes[state.range(0)]);
  const Tucker model = hooi(synthetic_brick(3), {kRank, kRank, kRank});
  const std::vector<std::byte> bytes = quant::serialize(quant::quantize(model, scheme), scheme);
  quant::DequantizedModel decoded;
  for (auto _ : state) {
    quant::dequantize(quant::BrickView(bytes, scheme), {kRank, kRank, kRank}, decoded);
    benchmark::DoNotOptimize(decoded.core.data());
  }
  state.counters["bricks/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(kSchemes[state.range(0)]);
}
BENCHMARK(BM_Dequantize)->ArgName("scheme")->DenseRange(0, 7);

// Quality of each scheme on the synthetic brick (paper Fig. 7 style): SNR of the quantized
// rank-16 model against the input, next to the unquantized model's, and bytes per brick.
void BM_SchemeQuality(benchmark::State& state) {
  const quant::QuantScheme scheme = quant::QuantScheme::parse(kSchemes[state.range(0)]);
  const Tensor3 brick = synthetic_brick(4);
  const Tucker model = hooi(brick, {kRank, kRank, kRank});
  std::vector<std::byte> bytes;
  for (auto _ : state) bytes = quant::serialize(quant::quantize(model, scheme), scheme);
  const Tucker back = quant::dequantize(quant::deserialize(bytes, scheme), scheme);
  auto snr = [&](const Tucker& m) {
    const Tensor3 approx = reconstruct(m.core, m.factors);
    double signal = 0, noise = 0;
    for (std::int64_t i = 0; i < brick.size(); ++i) {
      signal += double(brick.data()[i]) * brick.data()[i];
      noise += (double(brick.data()[i]) - approx.data()[i]) * (double(brick.data()[i]) - approx.data()[i]);
    }
    return 10 * std::log10(signal / noise);
  };
  state.counters["snr_db"] = snr(back);
  state.counters["snr_unquantized_db"] = snr(model);
  state.counters["bytes"] = double(bytes.size());
  state.counters["bits/voxel"] = 8.0 * double(bytes.size()) / double(brick.size());
  state.SetLabel(kSchemes[state.range(0)]);
}
BENCHMARK(BM_SchemeQuality)->ArgName("scheme")->DenseRange(0, 7)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace strata::tensor

// Per-core numbers: Eigen would otherwise spread the decomposition's small GEMMs over OpenMP
// threads when called outside a parallel region (the compressor calls it inside one, where
// Eigen runs sequentially anyway).
int main(int argc, char** argv) {
  Eigen::setNbThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
