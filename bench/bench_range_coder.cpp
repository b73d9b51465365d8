// Range coder benchmarks (strata/core/range_coder.hpp): decode throughput of skewed adaptive
// bits and of Exp-Golomb integers of Laplacian coefficients (the shape of quantized Tucker
// cores), and encode throughput for comparison. Counters: `bits` coded per second (shown as
// M/s), `per_int` time per integer (ns), and the stream's cost per symbol.
//   ./bench_range_coder --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "strata/core/range_coder.hpp"
#include "strata/quant/coded_brick.hpp"

namespace strata {
namespace {

constexpr std::size_t kBits = 1 << 20;
constexpr std::size_t kIntegers = 1 << 16;

std::vector<int> skewed_bits(double p1) {
  std::mt19937_64 rng(1);
  std::bernoulli_distribution one(p1);
  std::vector<int> bits(kBits);
  for (int& b : bits) b = one(rng) ? 1 : 0;
  return bits;
}

// Magnitudes of rounded Laplacian values of scale `b`, minus one where nonzero: what
// encode_nonzero passes to encode_uint. Zeros are left out (the caller's zero flag codes them).
std::vector<std::uint32_t> laplacian_magnitudes(double b) {
  std::mt19937_64 rng(2);
  std::exponential_distribution<double> exp(1.0 / b);
  std::vector<std::uint32_t> values;
  while (values.size() < kIntegers)
    if (const long q = std::lround(exp(rng) - exp(rng)); q != 0) values.push_back(std::uint32_t(std::labs(q) - 1));
  return values;
}

std::vector<std::byte> encode_bits(const std::vector<int>& bits) {
  RangeEncoder enc;
  BitModel m;
  for (int b : bits) enc.encode_bit(m, b);
  return enc.finish();
}

// Arg: 1 / p1 (p1 = probability of a 1).
void BM_DecodeSkewedBits(benchmark::State& state) {
  const std::vector<int> bits = skewed_bits(1.0 / double(state.range(0)));
  const std::vector<std::byte> stream = encode_bits(bits);
  for (auto _ : state) {
    RangeDecoder dec(stream, "bench", "bits");
    BitModel m;
    int ones = 0;
    for (std::size_t i = 0; i < kBits; ++i) ones += dec.decode_bit(m);
    benchmark::DoNotOptimize(ones);
  }
  state.counters["bits"] = benchmark::Counter(double(kBits) * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["bits/bit"] = double(stream.size()) * 8.0 / double(kBits);
}
BENCHMARK(BM_DecodeSkewedBits)->ArgName("1/p1")->Arg(2)->Arg(10)->Arg(100)->Arg(1000)->Unit(benchmark::kMillisecond);

void BM_EncodeSkewedBits(benchmark::State& state) {
  const std::vector<int> bits = skewed_bits(1.0 / double(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(encode_bits(bits));
  state.counters["bits"] = benchmark::Counter(double(kBits) * double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_EncodeSkewedBits)->ArgName("1/p1")->Arg(2)->Arg(10)->Arg(100)->Unit(benchmark::kMillisecond);

// Arg: the Laplacian scale b.
void BM_DecodeExpGolomb(benchmark::State& state) {
  const std::vector<std::uint32_t> values = laplacian_magnitudes(double(state.range(0)));
  RangeEncoder enc;
  UIntModel em;
  for (std::uint32_t v : values) encode_uint(enc, em, v);
  const std::vector<std::byte> stream = enc.finish();
  for (auto _ : state) {
    RangeDecoder dec(stream, "bench", "integers");
    UIntModel m;
    std::uint32_t sum = 0;
    for (std::size_t i = 0; i < kIntegers; ++i) sum += decode_uint(dec, m);
    benchmark::DoNotOptimize(sum);
  }
  state.counters["per_int"] = benchmark::Counter(double(kIntegers) * double(state.iterations()),
                                                 benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["bits/int"] = double(stream.size()) * 8.0 / double(kIntegers);
}
BENCHMARK(BM_DecodeExpGolomb)->ArgName("b")->Arg(2)->Arg(20)->Arg(200)->Arg(5000)->Unit(benchmark::kMicrosecond);

void BM_EncodeExpGolomb(benchmark::State& state) {
  const std::vector<std::uint32_t> values = laplacian_magnitudes(double(state.range(0)));
  for (auto _ : state) {
    RangeEncoder enc;
    UIntModel m;
    for (std::uint32_t v : values) encode_uint(enc, m, v);
    benchmark::DoNotOptimize(enc.finish());
  }
  state.counters["per_int"] = benchmark::Counter(double(kIntegers) * double(state.iterations()),
                                                 benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_EncodeExpGolomb)->ArgName("b")->Arg(2)->Arg(200)->Unit(benchmark::kMicrosecond);

// A block-DCT coded brick shaped like the encoder's at 40 dB on EM data: 32^3 with 2 overlap
// rows, blocks of 7, full ranks 28, core codes Laplacian with a scale that halves every 2 units
// of summed frequency (about two thirds of them 0), 4 coded overlap rows per column.
quant::CodedBrick dct_coded_brick() {
  quant::CodedBrick b;
  b.dims = {32, 32, 32};
  b.ranks = {28, 28, 28};
  b.offset = 100;
  b.core_step = 2;
  b.dct_block = 7;
  b.margin = 2;
  std::mt19937_64 rng(3);
  std::exponential_distribution<double> exp(1.0);
  for (int k = 0; k < 28; ++k)
    for (int j = 0; j < 28; ++j)
      for (int i = 0; i < 28; ++i) {
        const double scale = 8.0 * std::exp2(-double(i / 4 + j / 4 + k / 4) / 2.0);
        b.core_codes.push_back(std::int32_t(std::lround(scale * (exp(rng) - exp(rng)))));
      }
  b.factor_step_codes.assign(84, 40);
  for (int c = 0; c < 84 * 4; ++c) b.factor_codes.push_back(std::int32_t(std::lround(20 * (exp(rng) - exp(rng)))));
  b.error_table.assign(28, 70);
  return b;
}

void BM_SerializeCodedBrick(benchmark::State& state) {
  const quant::CodedBrick b = dct_coded_brick();
  std::size_t bytes = 0;
  for (auto _ : state) {
    const std::vector<std::byte> out = quant::serialize(b);
    bytes = out.size();
    benchmark::DoNotOptimize(out.data());
  }
  std::size_t zeros = 0;
  for (std::int32_t c : b.core_codes) zeros += c == 0;
  state.counters["coefficients"] =
      benchmark::Counter(double(b.core_codes.size()) * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["bits/coefficient"] = double(bytes) * 8.0 / double(b.core_codes.size());
  state.counters["zero_share"] = double(zeros) / double(b.core_codes.size());
}
BENCHMARK(BM_SerializeCodedBrick)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace strata

BENCHMARK_MAIN();
