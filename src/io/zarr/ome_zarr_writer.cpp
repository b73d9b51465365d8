// OME-Zarr 0.4 output: a Zarr v2 group with one array per resolution level and the NGFF
// `multiscales` attributes.
//
// Written (the folder `<image>`):
// | file              | content                                                                 |
// | ----------------- | ----------------------------------------------------------------------- |
// | .zgroup           | {"zarr_format": 2}                                                      |
// | .zattrs           | multiscales[0]: version "0.4", axes z, y, x (type space, NGFF unit),    |
// |                   | datasets[L]: path "L", scale [sz, sy, sx], translation [oz, oy, ox]     |
// | L/.zarray         | shape [z, y, x], chunks 64^3 clipped to the shape, C order, fill 0,     |
// |                   | compressor blosc (zstd, shuffle) or null, dimension_separator "/"       |
// | L/kz/ky/kx        | the chunks, each whole (edge chunks padded with zeros, as Zarr wants)   |
#include <algorithm>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/io_detail.hpp"
#include "io/zarr/ome_zarr_writer.hpp"
#include "io/zarr/zarr_array.hpp"
#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/ome_zarr.hpp"

namespace strata::io {

namespace detail {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr std::int64_t kChunkEdge = 64;

// NGFF's unit names for the canonical length units (canonical_length_unit); others are left out.
std::string ngff_unit(const std::string& unit) {
  const std::string canonical = canonical_length_unit(unit);
  if (canonical == "mm") return "millimeter";
  if (canonical == "um") return "micrometer";
  if (canonical == "nm") return "nanometer";
  if (canonical == "angstrom") return "angstrom";
  if (canonical == "cm") return "centimeter";
  if (canonical == "m") return "meter";
  return {};
}

void write_json(const fs::path& file, const json& j) { write_file_atomically(file, j.dump(2)); }

// The level's entry of multiscales[0].datasets.
json dataset_entry(const std::string& name, const VolumeInfo& info) {
  const Vector3& o = info.geometry.origin;
  return {{"path", name},
          {"coordinateTransformations",
           json::array({{{"type", "scale"}, {"scale", {info.spacing.z, info.spacing.y, info.spacing.x}}},
                        {{"type", "translation"}, {"translation", {o[2], o[1], o[0]}}}})}};
}

}  // namespace

json multiscales_attributes(const std::string& name, const std::vector<VolumeInfo>& levels) {
  json axes = json::array();
  const std::string unit = ngff_unit(levels.front().geometry.unit);
  for (const char* axis : {"z", "y", "x"}) {
    json a = {{"name", axis}, {"type", "space"}};
    if (!unit.empty()) a["unit"] = unit;
    axes.push_back(a);
  }
  json datasets = json::array();
  for (std::size_t l = 0; l < levels.size(); ++l) datasets.push_back(dataset_entry(std::to_string(l), levels[l]));
  return {{"multiscales", json::array({{{"version", "0.4"}, {"name", name}, {"axes", axes}, {"datasets", datasets}}})}};
}

Extent ome_zarr_chunk_shape(const VolumeInfo& info) {
  return {std::min(kChunkEdge, info.dims.x), std::min(kChunkEdge, info.dims.y), std::min(kChunkEdge, info.dims.z)};
}

json ome_zarr_array_metadata(const VolumeInfo& info, bool compress) {
  const Extent chunk = ome_zarr_chunk_shape(info);
  return {{"zarr_format", 2},
          {"shape", {info.dims.z, info.dims.y, info.dims.x}},
          {"chunks", {chunk.z, chunk.y, chunk.x}},
          {"dtype", zarr_v2_dtype(info.dtype)},
          {"compressor", compress ? blosc_zstd_compressor_json() : json()},
          {"fill_value", 0},
          {"order", "C"},
          {"filters", nullptr},
          {"dimension_separator", "/"}};
}

std::vector<std::byte> ome_zarr_stored_chunk(const Volume& part, const Extent& chunk, bool compress) {
  const Extent d = part.dims();
  if (d.x > chunk.x || d.y > chunk.y || d.z > chunk.z)
    throw Error(fmt::format("a Zarr chunk of {} cannot hold {} samples", chunk.to_string(), d.to_string()));
  const std::size_t sample = dtype_size(part.dtype());
  // Zarr chunks are whole: the part beyond the array's edge is zeros (the fill value).
  std::vector<std::byte> bytes(std::size_t(chunk.voxel_count()) * sample, std::byte{0});
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      std::memcpy(bytes.data() + std::size_t((z * chunk.y + y) * chunk.x) * sample,
                  part.bytes() + std::size_t((z * d.y + y) * d.x) * sample, std::size_t(d.x) * sample);
  return compress ? blosc_zstd_compress(bytes, sample) : bytes;
}

namespace {

// One Zarr v2 array of a level, fed slabs in z order; a chunk row (kChunkEdge slices) is kept
// until it is full, then written chunk by chunk.
class ArrayWriter {
 public:
  ArrayWriter(fs::path dir, const VolumeInfo& info, bool compress)
      : dir_(std::move(dir)), info_(info), compress_(compress), chunk_(ome_zarr_chunk_shape(info)),
        row_({info.dims.x, info.dims.y, chunk_.z}, info.dtype) {
    fs::create_directories(dir_);
    write_json(dir_ / ".zarray", ome_zarr_array_metadata(info, compress));
  }

  void write_slab(const Volume& slab) {
    const std::size_t slice = info_.bytes_per_slice();
    for (std::int64_t z = 0; z < slab.dims().z; ++z) {
      std::memcpy(row_.bytes() + std::size_t(filled_) * slice, slab.bytes() + std::size_t(z) * slice, slice);
      if (++filled_ == chunk_.z) flush_row();
    }
  }

  void finish() {
    if (filled_ > 0) flush_row();
  }

 private:
  void flush_row() {
    for (std::int64_t cy = 0; cy * chunk_.y < info_.dims.y; ++cy)
      for (std::int64_t cx = 0; cx * chunk_.x < info_.dims.x; ++cx) write_chunk(cx, cy);
    ++row_index_;
    filled_ = 0;
  }

  void write_chunk(std::int64_t cx, std::int64_t cy) {
    const std::int64_t x0 = cx * chunk_.x, y0 = cy * chunk_.y;
    const Box part{{x0, y0, 0}, {std::min(x0 + chunk_.x, info_.dims.x), std::min(y0 + chunk_.y, info_.dims.y), filled_}};
    const std::vector<std::byte> chunk = ome_zarr_stored_chunk(row_.crop(part), chunk_, compress_);
    const fs::path folder = dir_ / std::to_string(row_index_) / std::to_string(cy);
    fs::create_directories(folder);
    const fs::path file = folder / std::to_string(cx);
    std::ofstream out(file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(chunk.data()), std::streamsize(chunk.size()));
    if (!out) throw Error(fmt::format("{}: cannot write the chunk: {}", file.string(), system_error_text()));
  }

  fs::path dir_;
  VolumeInfo info_;
  bool compress_;
  Extent chunk_;
  Volume row_;  // chunk_.z slices
  std::int64_t filled_ = 0, row_index_ = 0;
};

// The image folder, written as `<path>.tmp` and renamed over `path` by commit(); removed when
// destroyed uncommitted.
class ImageFolder {
 public:
  explicit ImageFolder(fs::path path)
      : path_(std::move(path)), tmp_(path_.string() + std::string(kTemporarySuffix)), tmp_on_signal_(tmp_) {
    fs::remove_all(tmp_);
    fs::create_directories(tmp_);
    write_json(tmp_ / ".zgroup", {{"zarr_format", 2}});
  }
  ~ImageFolder() {
    std::error_code ec;
    if (!committed_) fs::remove_all(tmp_, ec);
  }
  ImageFolder(const ImageFolder&) = delete;
  ImageFolder& operator=(const ImageFolder&) = delete;
  const fs::path& tmp() const { return tmp_; }
  void commit(const std::vector<VolumeInfo>& levels) {
    std::string name = path_.filename().string();
    if (const auto dot = name.find('.'); dot != std::string::npos && dot > 0) name.resize(dot);
    write_json(tmp_ / ".zattrs", multiscales_attributes(name, levels));
    std::error_code ec;
    fs::remove_all(path_, ec);
    fs::rename(tmp_, path_, ec);
    if (ec) throw Error(fmt::format("{}: cannot rename {} to it: {}", path_.string(), tmp_.string(), ec.message()));
    tmp_on_signal_.release();
    committed_ = true;
  }

 private:
  fs::path path_, tmp_;
  RemovedOnSignal tmp_on_signal_;
  bool committed_ = false;
};

class OmeZarrWriter final : public VolumeWriter {
 public:
  OmeZarrWriter(const fs::path& path, const VolumeInfo& info, bool compress)
      : folder_(path), info_(info), level0_(folder_.tmp() / "0", info, compress) {}
  void write_slab(const Volume& slab) override { level0_.write_slab(slab); }
  void finish() override {
    level0_.finish();
    folder_.commit({info_});
  }

 private:
  ImageFolder folder_;
  VolumeInfo info_;
  ArrayWriter level0_;
};

}  // namespace

std::unique_ptr<VolumeWriter> make_ome_zarr_writer(const fs::path& path, const VolumeInfo& info, const WriteOptions& options) {
  return std::make_unique<OmeZarrWriter>(path, info, options.compress);
}

}  // namespace detail

void write_ome_zarr_pyramid(const std::filesystem::path& path, const std::vector<VolumeSource*>& levels,
                            const WriteOptions& options) {
  if (levels.empty()) throw ParameterError("levels", "an OME-Zarr image needs at least one level");
  std::vector<VolumeInfo> infos;
  for (VolumeSource* level : levels) {
    if (!level || level->info().dtype != levels.front()->info().dtype)
      throw ParameterError("levels", "every level must be a source of the same sample type");
    infos.push_back(level->info());
  }
  detail::ImageFolder folder(path);
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const VolumeInfo& info = infos[l];
    detail::ArrayWriter array(folder.tmp() / std::to_string(l), info, options.compress);
    for (std::int64_t z = 0; z < info.dims.z; z += detail::kChunkEdge)
      array.write_slab(levels[l]->read_slab(z, std::min(info.dims.z, z + detail::kChunkEdge)));
    array.finish();
  }
  folder.commit(infos);
}

}  // namespace strata::io
