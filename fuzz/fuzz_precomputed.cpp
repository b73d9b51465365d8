// Neuroglancer precomputed: the parts that read bytes from a store, each on arbitrary input. The
// first byte picks one:
//   0: a compressed_segmentation chunk (bytes 1-8: chunk and block dims, channels, u32 or u64;
//      then the chunk), every channel decoded;
//   1: a shard file (byte 1: minishard bits, gzip index flag; then the file): every minishard's
//      index located and searched for chunk ids 0..7;
//   2: an `info` file (the rest), opened and read as `strata info` reads it (no chunk files:
//      zeros), so the JSON checks and the sizes they guard run.
#include <filesystem>
#include <vector>

#include "io/io_detail.hpp"
#include "io/precomputed/compressed_segmentation.hpp"
#include "io/precomputed/sharding.hpp"
#include "support.hpp"

namespace {

using namespace strata::io::detail::precomputed;

void fuzz_compressed_segmentation(std::span<const std::byte> in) {
  if (in.size() < 8) return;
  const auto b = [&](std::size_t i) { return std::to_integer<std::int64_t>(in[i]); };
  const strata::Extent chunk{b(0) % 16 + 1, b(1) % 16 + 1, b(2) % 16 + 1};
  const strata::Extent block{b(3) % 8 + 1, b(4) % 8 + 1, b(5) % 8 + 1};
  const std::int64_t channels = b(6) % 3 + 1;
  const strata::DType dtype = b(7) & 1 ? strata::DType::u64 : strata::DType::u32;
  std::vector<std::byte> out(std::size_t(chunk.x * chunk.y * chunk.z) * strata::dtype_size(dtype));
  for (std::int64_t c = 0; c < channels; ++c)
    strata::fuzz::run_guarded(
        [&] { decode_compressed_segmentation(in.subspan(8), chunk, block, channels, c, dtype, out.data(), "chunk"); });
}

void fuzz_shard(std::span<const std::byte> in) {
  if (in.empty()) return;
  const auto flags = std::to_integer<unsigned>(in[0]);
  const ShardingSpec spec{.minishard_bits = int(flags % 4), .gzip_minishard_index = (flags & 0x80) != 0};
  const std::span<const std::byte> file = in.subspan(1);
  if (file.size() < shard_index_bytes(spec)) return;
  for (std::uint64_t m = 0; m < (std::uint64_t(1) << spec.minishard_bits); ++m)
    strata::fuzz::run_guarded([&] {
      const ByteRange range = minishard_index_range(file.subspan(16 * m, 16), spec, file.size(), "shard");
      const std::byte* at = file.data() + range.begin;
      const std::vector<std::byte> index =
          spec.gzip_minishard_index
              ? strata::io::detail::gunzip_to_memory(at, range.end - range.begin, "shard", "minishard index", 1 << 20)
              : std::vector<std::byte>(at, file.data() + range.end);
      for (std::uint64_t id = 0; id < 8; ++id) find_chunk(index, id, spec, file.size(), "shard");
    });
}

void fuzz_info(std::span<const std::byte> in) {
  std::filesystem::create_directories(strata::fuzz::temp_dir() / "volume.precomputed");
  const auto info = strata::fuzz::write_input("volume.precomputed/info", in);
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(info.parent_path(), {}); });
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> in = strata::fuzz::as_bytes(data, size);
  if (in.empty()) return 0;
  switch (std::to_integer<unsigned>(in[0]) % 3) {
    case 0: fuzz_compressed_segmentation(in.subspan(1)); break;
    case 1: fuzz_shard(in.subspan(1)); break;
    default: fuzz_info(in.subspan(1)); break;
  }
  return 0;
}
