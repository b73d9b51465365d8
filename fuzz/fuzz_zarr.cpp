// Zarr stores, read as `strata info` reads them. An input that starts with a zip signature
// ("PK\3\4") is a zip store, written as is to `input.zarr.zip`: the central directory and
// member parsing (zip64, stored and deflated members, crc32) and everything behind them see it.
// Any other input is array metadata (a `.zarray`, or a `zarr.json` when it names a node_type),
// a NUL byte, then the bytes of chunk (0, 0, 0), stored under each of the keys "0.0.0", "0/0/0"
// and "c/0/0/0" so every key encoding finds it; with sharding_indexed metadata those bytes are
// shard (0, 0, 0): its index and inner chunks. The metadata parser (shape, chunk and fill
// checks, codecs, sharding) and the chunk decoders (gzip, zlib, zstd, blosc, crc32c, byte order,
// transpose, shard indexes) see hostile bytes. Seeds: fuzz/corpus/zarr, small stores in these
// layouts (fuzz/tools/zarr_seeds.py writes the sharded and zip ones).
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string_view>

#include "support.hpp"

namespace {

void write_bytes(const std::filesystem::path& path, std::span<const std::byte> bytes) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> input = strata::fuzz::as_bytes(data, size);
  if (size >= 4 && std::memcmp(data, "PK\3\4", 4) == 0) {
    const std::filesystem::path zip = strata::fuzz::temp_dir() / "input.zarr.zip";
    write_bytes(zip, input);
    strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(zip, {}); });
    return 0;
  }
  const auto nul = std::find(input.begin(), input.end(), std::byte{0});
  const std::span<const std::byte> metadata(input.begin(), nul);
  const std::span<const std::byte> chunk = nul == input.end() ? std::span<const std::byte>() : std::span(nul + 1, input.end());
  const std::string_view text(reinterpret_cast<const char*>(metadata.data()), metadata.size());

  const std::filesystem::path store = strata::fuzz::temp_dir() / "input.zarr";
  std::filesystem::remove_all(store);
  write_bytes(store / (text.find("node_type") != std::string_view::npos ? "zarr.json" : ".zarray"), metadata);
  for (const char* key : {"0.0.0", "0/0/0", "c/0/0/0"}) write_bytes(store / key, chunk);
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(store, {}); });
  return 0;
}
