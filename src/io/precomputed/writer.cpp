// Writing precomputed volumes (include/strata/io/precomputed.hpp): each scale buffers one chunk
// row (64 slices of the whole x-y plane), then encodes and writes its chunks as unsharded files
// `<key>/<x0>-<x1>_<y0>-<y1>_<z0>-<z1>`. The `info` file is written last, then the temporary
// folder is renamed into place.
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "io/precomputed/chunk_codec.hpp"
#include "io/precomputed/info.hpp"
#include "io/precomputed/pyramid.hpp"
#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/precomputed.hpp"

namespace strata::io {

namespace {

namespace fs = std::filesystem;
using namespace detail::precomputed;

constexpr std::int64_t kChunkSize = kWrittenChunkEdge;

void write_file(const fs::path& path, const std::vector<std::byte>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  if (!out.flush()) throw Error(fmt::format("{}: cannot write: {}", path.string(), detail::system_error_text()));
}

// One scale: slabs in, chunk files out, a chunk row at a time.
class ScaleWriter final : public VolumeWriter {
 public:
  ScaleWriter(fs::path folder, Scale scale, DType dtype)
      : folder_(std::move(folder)), scale_(std::move(scale)), dtype_(dtype) {
    fs::create_directories(folder_);
  }

  void write_slab(const Volume& slab) override {
    const Extent& d = scale_.size;
    if (slab.dims().x != d.x || slab.dims().y != d.y || slab.dtype() != dtype_ || written_ + slab.dims().z > d.z)
      throw Error(fmt::format("{}: a slab of {} {} does not continue a {} {} scale at slice {}", folder_.string(),
                              slab.dims().to_string(), dtype_name(slab.dtype()), d.to_string(), dtype_name(dtype_),
                              written_));
    const std::size_t slice = std::size_t(d.x * d.y) * dtype_size(dtype_);
    for (std::int64_t z = 0; z < slab.dims().z; ++z) {
      if (row_.dims().z == 0) row_ = Volume({d.x, d.y, std::min(scale_.chunk.z, d.z - written_)}, dtype_);
      std::memcpy(row_.bytes() + std::size_t(filled_) * slice, slab.bytes() + std::size_t(z) * slice, slice);
      ++written_;
      if (++filled_ == row_.dims().z) flush_row();
    }
  }

  void finish() override {
    if (written_ != scale_.size.z)
      throw Error(
          fmt::format("{}: scale {} got {} of its {} slices", folder_.string(), scale_.key, written_, scale_.size.z));
  }

 private:
  void flush_row() {
    const std::int64_t z0 = written_ - filled_;
    const Extent& c = scale_.chunk;
    for (std::int64_t y0 = 0; y0 < scale_.size.y; y0 += c.y)
      for (std::int64_t x0 = 0; x0 < scale_.size.x; x0 += c.x) {
        const Box box{{x0, y0, 0}, {std::min(x0 + c.x, scale_.size.x), std::min(y0 + c.y, scale_.size.y), filled_}};
        const Volume chunk = row_.crop(box);
        const std::string name = chunk_name(scale_, {x0 / c.x, y0 / c.y, z0 / c.z});
        write_file(folder_ / name, encode_chunk(chunk.bytes(), chunk.dims(), scale_, dtype_));
      }
    row_ = Volume();
    filled_ = 0;
  }

  fs::path folder_;
  Scale scale_;
  DType dtype_;
  Volume row_;                // the chunk row being filled
  std::int64_t filled_ = 0;   // its slices received
  std::int64_t written_ = 0;  // slices received in all
};

}  // namespace

struct PrecomputedPyramidWriter::Impl {
  fs::path folder, temporary;
  RemovedOnSignal temporary_on_signal;
  VolumeDescription description;
  std::vector<std::unique_ptr<ScaleWriter>> scales;
  bool finished = false;
};

PrecomputedPyramidWriter::PrecomputedPyramidWriter(fs::path folder, std::vector<VolumeInfo> levels,
                                                   const PrecomputedEncoding& encoding)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.folder = std::move(folder);
  m.temporary = fs::path(m.folder.string() + std::string(kTemporarySuffix));
  m.temporary_on_signal = RemovedOnSignal(m.temporary);
  m.description = written_description(levels, m.folder.string(), encoding);
  std::error_code ec;
  if (fs::exists(m.folder, ec) && !fs::exists(m.folder / "info", ec))
    throw Error(fmt::format("{}: exists and is not a precomputed volume; not replaced", m.folder.string()));
  fs::remove_all(m.temporary, ec);
  for (const Scale& scale : m.description.scales)
    m.scales.push_back(std::make_unique<ScaleWriter>(m.temporary / scale.key, scale, m.description.dtype));
}

PrecomputedPyramidWriter::~PrecomputedPyramidWriter() {
  if (impl_ && !impl_->finished) {
    std::error_code ec;
    fs::remove_all(impl_->temporary, ec);
  }
}

VolumeWriter& PrecomputedPyramidWriter::level(std::size_t level) {
  if (level >= impl_->scales.size())
    throw Error(
        fmt::format("{}: no scale {} (the volume has {})", impl_->folder.string(), level, impl_->scales.size()));
  return *impl_->scales[level];
}

void PrecomputedPyramidWriter::finish() {
  Impl& m = *impl_;
  for (auto& scale : m.scales) scale->finish();
  detail::write_file_atomically(m.temporary / "info", info_json(m.description).dump(1) + "\n");
  std::error_code ec;
  fs::remove_all(m.folder, ec);
  fs::rename(m.temporary, m.folder, ec);
  if (ec)
    throw Error(fmt::format("{}: cannot rename {} to it: {}", m.folder.string(), m.temporary.string(), ec.message()));
  m.temporary_on_signal.release();
  m.finished = true;
}

void write_precomputed(const fs::path& folder, std::span<VolumeSource* const> levels) {
  std::vector<VolumeInfo> infos;
  for (const VolumeSource* source : levels) infos.push_back(source->info());
  PrecomputedPyramidWriter writer(folder, infos);
  for (std::size_t i = 0; i < levels.size(); ++i)
    for (std::int64_t z = 0; z < infos[i].dims.z; z += kChunkSize)
      writer.level(i).write_slab(levels[i]->read_slab(z, std::min(z + kChunkSize, infos[i].dims.z)));
  writer.finish();
}

}  // namespace strata::io
