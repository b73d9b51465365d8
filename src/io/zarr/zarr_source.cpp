// Box reads from a Zarr array through a bounded LRU cache of decoded chunks, the chunks of one
// box decoded in parallel.
#include "io/zarr/zarr_source.hpp"

#include <algorithm>
#include <array>
#include <exception>
#include <cstring>
#include <list>
#include <map>
#include <mutex>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "io/zarr/zarr_chunk_reader.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;
using ChunkIndex = std::vector<std::int64_t>;
using Chunk = std::shared_ptr<const std::vector<std::byte>>;

// The most recently used decoded chunks, at most `capacity` of them.
class ChunkCache {
 public:
  explicit ChunkCache(std::size_t capacity) : capacity_(capacity) {}
  Chunk find(const ChunkIndex& index) {
    std::lock_guard lock(mutex_);
    const auto it = where_.find(index);
    if (it == where_.end()) return nullptr;
    order_.splice(order_.begin(), order_, it->second);
    return it->second->second;
  }
  void insert(const ChunkIndex& index, Chunk chunk) {
    std::lock_guard lock(mutex_);
    if (where_.count(index)) return;  // another thread decoded it meanwhile
    order_.emplace_front(index, std::move(chunk));
    where_[index] = order_.begin();
    if (order_.size() > capacity_) {
      where_.erase(order_.back().first);
      order_.pop_back();
    }
  }

 private:
  using Entry = std::pair<ChunkIndex, Chunk>;
  std::size_t capacity_;
  std::mutex mutex_;
  std::list<Entry> order_;  // most recent first
  std::map<ChunkIndex, std::list<Entry>::iterator> where_;
};

class ZarrSource final : public VolumeSource {
 public:
  ZarrSource(ZarrArray array, ZarrView view, VolumeInfo info, fs::path path)
      : array_(std::move(array)),
        view_(std::move(view)),
        info_(std::move(info)),
        path_(std::move(path)),
        cache_(std::size_t(std::clamp<std::uint64_t>(kZarrCacheBytes / array_.chunk_bytes(), 1, kZarrCacheChunks))) {
    // Element strides of the logical axes inside a decoded chunk, whose axes are stored in
    // array_.stored_axis order (C order over them).
    const std::size_t rank = array_.shape.size();
    strides_.assign(rank, 0);
    std::int64_t stride = 1;
    for (std::size_t k = rank; k-- > 0;) {
      const auto axis = std::size_t(array_.stored_axis[k]);
      strides_[axis] = stride;
      stride *= array_.chunks[axis];
    }
  }

  const VolumeInfo& info() const override { return info_; }
  const fs::path& path() const override { return path_; }

  Volume read_box(const Box& box) override {
    check_box_inside(box, info_.dims, path_);
    Volume out(box.size(), info_.dtype, info_.spacing);
    const std::int64_t lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
    std::int64_t first[3], last[3];  // chunk ranges along x, y, z
    for (int a = 0; a < 3; ++a) {
      const std::int64_t c = chunk_extent(a);
      first[a] = lo[a] / c;
      last[a] = (hi[a] - 1) / c;
    }
    std::vector<std::array<std::int64_t, 3>> chunks;
    for (std::int64_t cz = first[2]; cz <= last[2]; ++cz)
      for (std::int64_t cy = first[1]; cy <= last[1]; ++cy)
        for (std::int64_t cx = first[0]; cx <= last[0]; ++cx) chunks.push_back({cx, cy, cz});
    // Chunks decode in parallel (each fills its own part of `out`); the first error is rethrown.
    std::exception_ptr error;
#pragma omp parallel for schedule(dynamic) if (chunks.size() > 1)
    for (std::size_t i = 0; i < chunks.size(); ++i) {
      try {
        copy_chunk(chunks[i], box, out);
      } catch (...) {
#pragma omp critical(zarr_read_error)
        if (!error) error = std::current_exception();
      }
    }
    if (error) std::rethrow_exception(error);
    return out;
  }

 private:
  // The array axis of spatial axis a (0 x, 1 y, 2 z), or -1 for the z of a 2-D image.
  int array_axis(int a) const {
    const int rank = int(array_.shape.size());
    return a < view_.spatial ? rank - 1 - a : -1;
  }
  std::int64_t chunk_extent(int a) const {
    const int axis = array_axis(a);
    return axis < 0 ? 1 : array_.chunks[std::size_t(axis)];
  }

  ChunkIndex chunk_index(const std::array<std::int64_t, 3>& spatial) const {
    ChunkIndex index(array_.shape.size());
    for (std::size_t i = 0; i < view_.leading_index.size(); ++i) index[i] = view_.leading_index[i] / array_.chunks[i];
    for (int a = 0; a < view_.spatial; ++a) index[std::size_t(array_axis(a))] = spatial[a];
    return index;
  }

  // The decoded chunk, or nullptr when it is not stored (all fill value).
  Chunk load(const ChunkIndex& index) {
    if (Chunk cached = cache_.find(index)) return cached;
    std::optional<EncodedChunk> encoded = reader_.read(index);
    if (!encoded) return nullptr;
    auto chunk = std::make_shared<const std::vector<std::byte>>(
        decode_zarr_chunk(array_, std::move(encoded->bytes), encoded->name));
    cache_.insert(index, chunk);
    return chunk;
  }

  void copy_chunk(const std::array<std::int64_t, 3>& spatial, const Box& box, Volume& out) {
    const ChunkIndex index = chunk_index(spatial);
    const Chunk chunk = load(index);
    const std::size_t sample = dtype_size(info_.dtype);
    // The part of the box inside this chunk, in volume coordinates.
    std::int64_t lo[3], hi[3];
    const std::int64_t box_lo[3] = {box.lo.x, box.lo.y, box.lo.z}, box_hi[3] = {box.hi.x, box.hi.y, box.hi.z};
    for (int a = 0; a < 3; ++a) {
      const std::int64_t c = chunk_extent(a);
      lo[a] = std::max(box_lo[a], spatial[a] * c);
      hi[a] = std::min(box_hi[a], (spatial[a] + 1) * c);
    }
    // Offset of the chunk's leading position, then per-axis strides (elements).
    std::int64_t base = 0;
    for (std::size_t i = 0; i < view_.leading_index.size(); ++i)
      base += (view_.leading_index[i] % array_.chunks[i]) * strides_[i];
    std::int64_t stride[3], origin[3];
    for (int a = 0; a < 3; ++a) {
      const int axis = array_axis(a);
      stride[a] = axis < 0 ? 0 : strides_[std::size_t(axis)];
      origin[a] = spatial[a] * chunk_extent(a);
    }
    const Extent d = out.dims();
    const std::int64_t run = hi[0] - lo[0];
    for (std::int64_t z = lo[2]; z < hi[2]; ++z)
      for (std::int64_t y = lo[1]; y < hi[1]; ++y) {
        std::byte* dst = out.bytes() + std::size_t(((z - box.lo.z) * d.y + (y - box.lo.y)) * d.x + (lo[0] - box.lo.x)) * sample;
        if (!chunk) {
          for (std::int64_t i = 0; i < run; ++i) std::memcpy(dst + std::size_t(i) * sample, array_.fill.data(), sample);
          continue;
        }
        const std::int64_t row = base + (z - origin[2]) * stride[2] + (y - origin[1]) * stride[1] + (lo[0] - origin[0]) * stride[0];
        const std::byte* src = chunk->data() + std::size_t(row) * sample;
        if (stride[0] == 1) {
          std::memcpy(dst, src, std::size_t(run) * sample);
        } else {
          for (std::int64_t i = 0; i < run; ++i)
            std::memcpy(dst + std::size_t(i) * sample, src + std::size_t(i * stride[0]) * sample, sample);
        }
      }
  }

  ZarrArray array_;
  ZarrChunkReader reader_{array_};  // after array_: it reads through it
  ZarrView view_;
  VolumeInfo info_;
  fs::path path_;
  std::vector<std::int64_t> strides_;  // element stride of each array axis in a decoded chunk
  ChunkCache cache_;
};

}  // namespace

std::unique_ptr<VolumeSource> make_zarr_source(ZarrArray array, ZarrView view, VolumeInfo info, fs::path path) {
  return std::make_unique<ZarrSource>(std::move(array), std::move(view), std::move(info), std::move(path));
}

}  // namespace strata::io::detail
