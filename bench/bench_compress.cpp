// Whole-file decoding: BM_DecodeWholeFile decodes level 0 of a 256^3 or 512^3 prisms file coded to
// 40 dB PSNR (TaVolume::decode_box of the whole level: entropy decoding, reconstruction, the
// copy into the output volume), per thread count.
// Whole-file compression throughput: a generated prisms volume (128^3 u16) served from memory
// through the streaming VolumeSource interface and compressed with the default settings (brick
// 32, overlap 2, rank 16, u16,b8log+, one HOOI sweep, zstd 3) into a temporary .strata file.
// The Mvox/s counter is input voxels per wall second, the number `strata compress` prints.
// Also the per-brick encoder alone (decomposition + quantization + zstd), on one core.
//   ./build/release/bench/bench_compress --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>

#include "strata/core/progress.hpp"
#include "strata/core/threads.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/files.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/brick_codec.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata {
namespace {

const Volume& prisms128() {
  static const Volume v = [] {
    gen::Params p;
    p.kind = gen::Kind::prisms;
    p.dims = {128, 128, 128};
    p.seed = 1;
    return gen::generate(p);
  }();
  return v;
}

// A Volume served through the streaming interface the compressor reads from.
class MemorySource final : public io::VolumeSource {
 public:
  explicit MemorySource(const Volume& v) : volume_(v) {}
  const VolumeInfo& info() const override { return volume_.info(); }
  const std::filesystem::path& path() const override { return path_; }
  Volume read_box(const Box& box) override { return volume_.crop(box); }

 private:
  const Volume& volume_;
  std::filesystem::path path_ = "prisms128";
};

ta::CompressParams default_params() {
  ta::CompressParams p;
  p.layout = {32, 2};
  p.codec.rank = 16;
  p.codec.quant = quant::QuantScheme::parse("u16,b8log+");
  p.codec.hooi_iterations = 1;
  p.codec.zstd_level = 3;
  return p;
}

// Arg: worker threads (strata --threads).
void BM_CompressPrisms128(benchmark::State& state) {
  const Volume& volume = prisms128();
  const ta::CompressParams params = default_params();
  set_thread_count(int(state.range(0)));
  io::TempFile out(std::filesystem::temp_directory_path(), "bench-compress");
  ta::CompressReport report;
  for (auto _ : state) {
    MemorySource source(volume);
    report = ta::compress_volume(source, out.path(), params, silent_progress());
  }
  set_thread_count(0);
  state.counters["Mvox/s"] = benchmark::Counter(double(volume.dims().voxel_count()) * double(state.iterations()) / 1e6,
                                                benchmark::Counter::kIsRate);
  state.counters["bits/voxel"] = 8.0 * double(report.file_bytes) / double(report.input_voxels);
}
BENCHMARK(BM_CompressPrisms128)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// The size^3 prisms file BM_DecodeWholeFile decodes, written once per run and size.
const std::filesystem::path& prisms_file(std::int64_t size) {
  static std::map<std::int64_t, std::unique_ptr<io::TempFile>> files;
  std::unique_ptr<io::TempFile>& file = files[size];
  if (!file) {
    file = std::make_unique<io::TempFile>(std::filesystem::temp_directory_path(), "bench-decode");
    gen::Params g;
    g.kind = gen::Kind::prisms;
    g.dims = {size, size, size};
    g.seed = 1;
    const Volume volume = gen::generate(g);
    ta::CompressParams p = default_params();
    p.codec.target = {ta::TargetKind::psnr, 40.0};
    MemorySource source(volume);
    ta::compress_volume(source, file->path(), p, silent_progress());
  }
  return file->path();
}

// Args: worker threads, volume edge.
void BM_DecodeWholeFile(benchmark::State& state) {
  const ta::TaVolume volume(prisms_file(state.range(1)));
  const Box whole = Box::whole(volume.geometry().level(0).dims);
  set_thread_count(int(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(volume.decode_box(0, whole, volume.rank()));
  set_thread_count(0);
  state.counters["Mvox/s"] = benchmark::Counter(double(whole.size().voxel_count()) * double(state.iterations()) / 1e6,
                                                benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DecodeWholeFile)
    ->ArgNames({"threads", "size"})
    ->Args({1, 256})
    ->Args({2, 256})
    ->Args({1, 512})
    ->Args({2, 512})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One brick's encoding (no decoding, no culling statistics): the compressor's per-brick work
// minus what the level pipeline adds. Bricks are taken from the volume's interior.
void BM_EncodeBrick(benchmark::State& state) {
  const Volume& volume = prisms128();
  const ta::CodecParams codec = default_params().codec;
  std::vector<tensor::Tensor3> bricks;
  for (std::int64_t z = 0; z + 32 <= 128; z += 48)
    for (std::int64_t y = 0; y + 32 <= 128; y += 48)
      for (std::int64_t x = 0; x + 32 <= 128; x += 48) {
        tensor::Tensor3 t(32, 32, 32);
        const auto samples = volume.samples<std::uint16_t>();
        for (std::int64_t k = 0; k < 32; ++k)
          for (std::int64_t j = 0; j < 32; ++j)
            for (std::int64_t i = 0; i < 32; ++i)
              t(i, j, k) = float(samples[std::size_t(((z + k) * 128 + (y + j)) * 128 + (x + i))]);
        bricks.push_back(std::move(t));
      }
  std::size_t next = 0, bytes = 0;
  for (auto _ : state) {
    const ta::EncodedBrick e = ta::encode_brick(bricks[next], codec);
    bytes += e.payload.size();
    next = (next + 1) % bricks.size();
  }
  state.counters["bricks/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["Mvox/s"] =
      benchmark::Counter(32.0 * 32 * 32 * double(state.iterations()) / 1e6, benchmark::Counter::kIsRate);
  state.counters["bytes/brick"] = double(bytes) / double(state.iterations());
}
BENCHMARK(BM_EncodeBrick)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace strata

BENCHMARK_MAIN();
