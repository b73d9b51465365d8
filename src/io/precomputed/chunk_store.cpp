// Reading encoded chunks: unsharded files `<key>/<x0>-<x1>_<y0>-<y1>_<z0>-<z1>` (gzip-compressed
// or not, detected by the gzip magic), or shard files `<key>/<shard>.shard` (sharding.hpp).
#include "io/precomputed/chunk_store.hpp"

#include <fstream>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "io/precomputed/pyramid.hpp"
#include "io/precomputed/sharding.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::precomputed {

namespace {

namespace fs = std::filesystem;


// The bytes of a whole (small) file, or nothing when it does not exist.
std::optional<Bytes> read_small_file(const fs::path& path, std::uint64_t limit, const std::string& field) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) {
    if (!fs::exists(path)) return std::nullopt;
    throw Error(fmt::format("{}: cannot read: {}", path.string(), ec.message()));
  }
  if (size > limit)
    throw FormatError(path.string(), field, fmt::format("{} bytes, more than a chunk can hold ({})", size, limit));
  Bytes bytes(size);
  std::ifstream in(path, std::ios::binary);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(size)))
    throw Error(fmt::format("{}: cannot read", path.string()));
  return bytes;
}

}  // namespace

ChunkStore::ChunkStore(fs::path folder, Scale scale, std::uint64_t max_encoded_bytes)
    : folder_(std::move(folder)),
      scale_(std::move(scale)),
      grid_(chunk_grid(scale_)),
      max_encoded_bytes_(max_encoded_bytes) {}

std::string ChunkStore::file_of(const Extent& position) const {
  if (scale_.sharding) {
    const std::uint64_t id = compressed_morton_code(position, grid_);
    return (folder_ / shard_slot(*scale_.sharding, id).file_name).string();
  }
  return (folder_ / chunk_name(scale_, position)).string();
}

std::optional<Bytes> ChunkStore::read(const Extent& position) const {
  return scale_.sharding ? read_sharded(position) : read_unsharded(position);
}

Bytes ChunkStore::decoded(const std::byte* data, std::uint64_t size, bool gzip, const std::string& file,
                          const std::string& field) const {
  if (!gzip) {
    if (size > max_encoded_bytes_)
      throw FormatError(file, field,
                        fmt::format("{} bytes, more than a chunk can hold ({})", size, max_encoded_bytes_));
    return Bytes(data, data + size);
  }
  Bytes out = gunzip_to_memory(data, size, file, field, max_encoded_bytes_ + 1);
  if (out.size() > max_encoded_bytes_)
    throw FormatError(file, field, fmt::format("decodes to more than a chunk can hold ({} bytes)", max_encoded_bytes_));
  return out;
}

std::optional<Bytes> ChunkStore::read_unsharded(const Extent& position) const {
  const std::string file = file_of(position);
  // A gzip-compressed chunk is smaller than what it decodes to, give or take its header.
  const std::optional<Bytes> bytes = read_small_file(file, max_encoded_bytes_ + 4096, "chunk");
  if (!bytes) return std::nullopt;
  return decoded(bytes->data(), bytes->size(), looks_gzipped(bytes->data(), bytes->size()), file, "chunk");
}

std::shared_ptr<const MappedFile> ChunkStore::shard(const std::string& name) const {
  {
    std::lock_guard lock(mutex_);
    if (auto cached = shards_.find(name)) return cached;
  }
  const fs::path path = folder_ / name;
  std::error_code ec;
  if (!fs::exists(path, ec)) return nullptr;
  std::shared_ptr<const MappedFile> file;
  if (fs::file_size(path, ec) == 0 && !ec) throw FormatError(path.string(), "shard index", "the shard file is empty");
  file = std::make_shared<const MappedFile>(path);
  std::lock_guard lock(mutex_);
  shards_.insert(name, file, 1);
  return file;
}

std::shared_ptr<const Bytes> ChunkStore::minishard_index(const std::string& shard_name, const MappedFile& file,
                                                         std::uint64_t minishard) const {
  const auto key = std::make_pair(shard_name, minishard);
  {
    std::lock_guard lock(mutex_);
    if (auto cached = minishards_.find(key)) return cached;
  }
  const std::string path = (folder_ / shard_name).string();
  const ShardingSpec& spec = *scale_.sharding;
  if (file.size() < shard_index_bytes(spec))
    throw FormatError(path, "shard index",
                      fmt::format("{} bytes, shorter than its index of {} bytes", file.size(),
                                  shard_index_bytes(spec)));
  const ByteRange range = minishard_index_range({file.data() + 16 * minishard, 16}, spec, file.size(), path);
  auto index = std::make_shared<const Bytes>(spec.gzip_minishard_index
                                                 ? gunzip_to_memory(file.data() + range.begin, range.end - range.begin,
                                                                    path, "minishard index", kMaxChunkBytes)
                                                 : Bytes(file.data() + range.begin, file.data() + range.end));
  std::lock_guard lock(mutex_);
  minishards_.insert(key, index, 1);
  return index;
}

std::optional<Bytes> ChunkStore::read_sharded(const Extent& position) const {
  const ShardingSpec& spec = *scale_.sharding;
  const std::uint64_t id = compressed_morton_code(position, grid_);
  const ShardSlot slot = shard_slot(spec, id);
  const std::shared_ptr<const MappedFile> file = shard(slot.file_name);
  if (!file) return std::nullopt;
  const std::string path = (folder_ / slot.file_name).string();
  const std::shared_ptr<const Bytes> index = minishard_index(slot.file_name, *file, slot.minishard);
  const std::optional<ByteRange> range = find_chunk(*index, id, spec, file->size(), path);
  if (!range) return std::nullopt;
  return decoded(file->data() + range->begin, range->end - range->begin, spec.gzip_data, path,
                 fmt::format("chunk {}", id));
}

}  // namespace strata::io::detail::precomputed
