// Neuroglancer precomputed volumes (connectomics, EM, light-sheet): a folder with an `info` JSON
// file (precomputed/info.cpp) and, per scale, a folder of chunks, unsharded or sharded
// (precomputed/chunk_store.cpp), encoded raw, jpeg or compressed_segmentation
// (precomputed/chunk_codec.cpp). A box read decodes only the chunks it touches; decoded chunks
// are kept in a bounded least-recently-used cache, so slab-by-slab reading decodes each once.
//
// Geometry: resolution (nm per voxel) is the spacing with unit "nm"; the origin (Strata's: the
// centre of voxel 0) is voxel_offset * resolution. Neuroglancer draws voxel i over [i, i + 1), so
// its centre there lies half a voxel further; that half voxel is left out both ways, so a round
// trip keeps voxel_offset exactly. The axes are x, y, z without direction cosines. Channels
// (num_channels) are the file's volumes.
#include "strata/io/precomputed.hpp"

#include <array>
#include <cstring>
#include <mutex>

#include <fmt/format.h>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "io/precomputed/chunk_codec.hpp"
#include "io/precomputed/chunk_store.hpp"
#include "io/precomputed/info.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;
using namespace precomputed;

// Decoded chunks kept per source: a chunk row of a 4096^2 u8 scale in 64^3 chunks, or of a
// 1024^2 uint64 one.
constexpr std::size_t kChunkCacheBytes = std::size_t(256) << 20;

VolumeInfo volume_info(const VolumeDescription& d, const Scale& s) {
  VolumeInfo info;
  info.dims = s.size;
  info.dtype = d.dtype;
  info.spacing = {s.resolution[0], s.resolution[1], s.resolution[2]};
  info.volumes = d.channels;
  info.geometry.unit = "nm";
  info.geometry.origin = {double(s.voxel_offset.x) * s.resolution[0], double(s.voxel_offset.y) * s.resolution[1],
                          double(s.voxel_offset.z) * s.resolution[2]};
  return info;
}

class PrecomputedSource final : public VolumeSource {
 public:
  PrecomputedSource(fs::path folder, VolumeDescription description, std::size_t level, std::int64_t channel)
      : path_(std::move(folder)),
        description_(std::move(description)),
        scale_(description_.scales[level]),
        channel_(channel),
        info_(volume_info(description_, scale_)),
        store_(path_ / scale_.key, scale_, max_encoded_chunk_bytes(scale_.chunk, description_)) {}

  const VolumeInfo& info() const override { return info_; }
  const fs::path& path() const override { return path_; }

  Volume read_box(const Box& box) override {
    check_box_inside(box, info_.dims, path_);
    Volume out(box.size(), info_.dtype, info_.spacing);
    const Extent& c = scale_.chunk;
    for (std::int64_t gz = box.lo.z / c.z; gz * c.z < box.hi.z; ++gz)
      for (std::int64_t gy = box.lo.y / c.y; gy * c.y < box.hi.y; ++gy)
        for (std::int64_t gx = box.lo.x / c.x; gx * c.x < box.hi.x; ++gx) copy_chunk({gx, gy, gz}, box, out);
    return out;
  }

 private:
  Box chunk_box(const Extent& position) const {
    const Extent& c = scale_.chunk;
    const Extent lo{position.x * c.x, position.y * c.y, position.z * c.z};
    return {lo,
            {std::min(lo.x + c.x, info_.dims.x), std::min(lo.y + c.y, info_.dims.y),
             std::min(lo.z + c.z, info_.dims.z)}};
  }

  // The decoded samples of chunk `position`, or nullptr for a missing chunk (zeros).
  std::shared_ptr<const Bytes> chunk(const Extent& position) {
    const std::array<std::int64_t, 3> key{position.x, position.y, position.z};
    {
      std::lock_guard lock(mutex_);
      if (auto cached = cache_.find(key)) return cached;
    }
    const std::optional<Bytes> encoded = store_.read(position);
    if (!encoded) return nullptr;
    auto decoded = std::make_shared<const Bytes>(
        decode_chunk(*encoded, chunk_box(position).size(), scale_, description_, channel_, store_.file_of(position)));
    std::lock_guard lock(mutex_);
    cache_.insert(key, decoded, decoded->size());
    return decoded;
  }

  void copy_chunk(const Extent& position, const Box& box, Volume& out) {
    const Box cbox = chunk_box(position);
    const Box part = cbox.intersect(box);
    if (part.empty()) return;
    const std::shared_ptr<const Bytes> samples = chunk(position);
    if (!samples) return;  // a missing chunk reads as zeros, which `out` holds already
    const std::size_t sample = dtype_size(info_.dtype);
    const Extent cd = cbox.size(), od = out.dims();
    const std::size_t row = std::size_t(part.hi.x - part.lo.x) * sample;
    for (std::int64_t z = part.lo.z; z < part.hi.z; ++z)
      for (std::int64_t y = part.lo.y; y < part.hi.y; ++y) {
        const std::size_t from =
            std::size_t(((z - cbox.lo.z) * cd.y + (y - cbox.lo.y)) * cd.x + (part.lo.x - cbox.lo.x));
        const std::size_t to = std::size_t(((z - box.lo.z) * od.y + (y - box.lo.y)) * od.x + (part.lo.x - box.lo.x));
        std::memcpy(out.bytes() + to * sample, samples->data() + from * sample, row);
      }
  }

  fs::path path_;
  VolumeDescription description_;
  Scale scale_;
  std::int64_t channel_;
  VolumeInfo info_;
  ChunkStore store_;
  std::mutex mutex_;
  LruCache<std::array<std::int64_t, 3>, Bytes> cache_{kChunkCacheBytes};
};

std::unique_ptr<VolumeSource> open_precomputed(const fs::path& path, const ReadOptions& options) {
  VolumeDescription description = read_info(path);
  const std::int64_t level = options.level.value_or(0);
  const auto levels = std::int64_t(description.scales.size());
  if (level < 0 || level >= levels)
    throw ParameterError("ReadOptions::level",
                         fmt::format("{}: level {} does not exist; the volume has {} scales (0..{})", path.string(),
                                     level, levels, levels - 1));
  const Scale& scale = description.scales[std::size_t(level)];
  const std::string info_file = (path / "info").string();
  const std::string scale_field = fmt::format("scales[{}].size", level);
  checked_volume_bytes(volume_info(description, scale), info_file, scale_field);
  const std::int64_t channel =
      choose_volume(description.channels, scale.size, options, info_file, "num_channels", "channels");
  return std::make_unique<PrecomputedSource>(path, std::move(description), std::size_t(level), channel);
}

// The format's one-scale writer: scale 0 of a pyramid writer.
class SingleScaleWriter final : public VolumeWriter {
 public:
  SingleScaleWriter(const fs::path& path, const VolumeInfo& info) : pyramid_(path, {info}) {}
  void write_slab(const Volume& slab) override { pyramid_.level(0).write_slab(slab); }
  void finish() override { pyramid_.finish(); }

 private:
  PrecomputedPyramidWriter pyramid_;
};

std::unique_ptr<VolumeWriter> create_precomputed_writer(const fs::path& path, const VolumeInfo& info,
                                                        const WriteOptions&) {
  return std::make_unique<SingleScaleWriter>(path, info);
}

}  // namespace

VolumeFormat precomputed_format() {
  return {
      .name = "precomputed",
      .title = "Neuroglancer precomputed",
      .description =
          "Neuroglancer's chunked multiscale volumes (connectomics, EM): a folder with an `info` JSON file "
          "and a folder of chunks per scale",
      .extensions = {".precomputed"},
      .directory = "a Neuroglancer precomputed folder (with an `info` file)",
      .sniff_directory = looks_like_precomputed,
      .open = open_precomputed,
      .create_writer = create_precomputed_writer,
      .files_written = [](const fs::path& path, const WriteOptions&) { return replaced_folder_written(path); },
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true, .multiscale = true},
      .read_dtypes = {DType::u8, DType::i8, DType::u16, DType::i16, DType::u32, DType::i32, DType::u64, DType::f32},
      .write_dtypes = {DType::u8, DType::i8, DType::u16, DType::i16, DType::u32, DType::i32, DType::u64, DType::f32},
      .read_notes =
          "local folders; any scale (`--level`), channels as volumes; raw, jpeg and compressed_segmentation "
          "chunks, plain or gzip; unsharded and sharded (identity or murmurhash3_x86_128, raw or gzip); "
          "missing chunks read as 0; resolution (nm) and voxel_offset as spacing and origin",
      .write_notes =
          "one scale, unsharded 64^3 chunks: u32/u64 as segmentation with compressed_segmentation, other "
          "types as raw images; resolution in nm, origin as voxel_offset; more scales through "
          "strata/io/precomputed.hpp",
  };
}

}  // namespace strata::io::detail
