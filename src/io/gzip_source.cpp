// make_gzip_source (io_detail.hpp): a volume in a gzip stream read as the reads need it. Passes in
// z order decode the stream as they go; anything else decodes the volume once into an unnamed
// temporary file, mapped from then on.
#include <algorithm>
#include <bit>
#include <cstring>
#include <mutex>
#include <optional>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "strata/core/checked.hpp"

namespace strata::io::detail {

namespace {

// Passes that start again at slice 0 decode the stream again this many times; the next one (or
// any other step back) decodes the volume to a temporary file instead.
constexpr int kMaxRestarts = 2;
constexpr std::uint64_t kDecodeChunk = std::uint64_t(1) << 20;
// What stays held after a read: its last slices up to this size (at least one), for a next
// read that overlaps it.
constexpr std::uint64_t kKeepBytes = std::uint64_t(16) << 20;
// Whole slices up to this size are decoded straight into the result (a slab pass); larger or
// partial reads go through the held bytes, which grow as the stream delivers them, so a stream
// far shorter than its header says fails before a large buffer is allocated.
constexpr std::uint64_t kDirectBytes = std::uint64_t(256) << 20;

class GzipSource final : public VolumeSource {
 public:
  GzipSource(std::shared_ptr<MappedFile> compressed, std::uint64_t start, GzipVolume volume, std::filesystem::path path,
             const ReadOptions& options)
      : compressed_(std::move(compressed)), start_(start), volume_(std::move(volume)), path_(std::move(path)),
        temp_dir_(options.temp_dir), progress_(options.progress),
        slice_bytes_(volume_.info.bytes_per_slice() * std::uint64_t(volume_.interleave.count)) {
    // The caller checked that the samples of every volume fit in 64 bits.
    region_end_ = volume_.offset + slice_bytes_ * std::uint64_t(volume_.info.dims.z);
    restart();  // a stream that does not start like gzip is refused when the file is opened
  }

  const VolumeInfo& info() const override { return volume_.info; }
  const std::filesystem::path& path() const override { return path_; }

  Volume read_box(const Box& box) override {
    check_box_inside(box, volume_.info.dims, path_);
    const std::lock_guard lock(mutex_);
    if (!mapped_) {
      const std::uint64_t first = volume_.offset + std::uint64_t(box.lo.z) * slice_bytes_;
      if (first < held_begin_ && !(box.lo.z == 0 && restarts_ < kMaxRestarts)) spill();
    }
    if (mapped_) return mapped_->read_box(box);
    const Extent& dims = volume_.info.dims;
    const bool whole_slices = box.lo.x == 0 && box.lo.y == 0 && box.hi.x == dims.x && box.hi.y == dims.y;
    if (whole_slices && volume_.interleave.count == 1 && std::uint64_t(box.hi.z - box.lo.z) * slice_bytes_ <= kDirectBytes)
      return read_slices(box);
    hold_slices(box.lo.z, box.hi.z);
    Volume result = copy_out(box);
    keep_tail();
    return result;
  }

 private:
  std::string file() const { return path_.string(); }

  // The stream ended before the bytes a read needs: the format's message.
  [[noreturn]] void ended_short() const {
    if (volume_.report_short) volume_.report_short(stream_->produced());
    throw FormatError(file(), volume_.field, fmt::format("the gzip stream ends after {} decoded bytes, short of the {} "
                                                         "{} declares", stream_->produced(), volume_.declared.bytes,
                                                         volume_.declared.declared_by));
  }

  void restart() {
    stream_ = std::make_unique<GzipStream>(compressed_->data() + start_, compressed_->size() - start_, file(),
                                           volume_.field);
    held_.clear();
    held_begin_ = 0;
  }

  // Whole slices of a volume that is not interleaved: the bytes held, then the stream, straight
  // into the result; its last slices are held afterwards.
  Volume read_slices(const Box& box) {
    const std::uint64_t begin = volume_.offset + std::uint64_t(box.lo.z) * slice_bytes_;
    const std::uint64_t end = volume_.offset + std::uint64_t(box.hi.z) * slice_bytes_;
    if (begin < held_begin_) {
      ++restarts_;
      restart();
    }
    const VolumeInfo& info = volume_.info;
    Volume result(box.size(), info.dtype, info.spacing);
    std::byte* out = result.bytes();
    const std::uint64_t held_end = held_begin_ + held_.size();  // where the stream is
    std::uint64_t at = begin;
    if (at < held_end) {
      const std::uint64_t n = std::min(end, held_end) - at;
      std::memcpy(out, held_.data() + (at - held_begin_), n);
      at += n;
    } else if (stream_->skip(at - held_end) != at - held_end) {
      ended_short();
    }
    if (at < end) {  // the stream is at `at`
      for (std::uint64_t filled = at - begin; filled < end - begin;) {
        const auto want = std::size_t(std::min<std::uint64_t>(end - begin - filled, kDecodeChunk));
        const std::size_t got = stream_->read(out + filled, want);
        if (got == 0) ended_short();
        filled += got;
      }
      if (end == volume_.declared.bytes) check_stream_ends();
      const std::uint64_t keep = std::min(end - begin, kept_bytes());
      held_.assign(out + (end - begin - keep), out + (end - begin));
      held_begin_ = end - keep;
    }
    const std::uint64_t sample = dtype_size(info.dtype);
    if (volume_.big_endian != (std::endian::native == std::endian::big))
      byte_swap(result.bytes(), result.byte_size() / sample, sample);
    return result;
  }

  // How much of the last slices stays held after a read.
  std::uint64_t kept_bytes() const { return std::max<std::uint64_t>(1, kKeepBytes / slice_bytes_) * slice_bytes_; }

  // Decoded bytes up to `end` are held from `begin` on (begin >= held_begin_ unless restarting).
  void hold_slices(std::int64_t z0, std::int64_t z1) {
    const std::uint64_t begin = volume_.offset + std::uint64_t(z0) * slice_bytes_;
    const std::uint64_t end = volume_.offset + std::uint64_t(z1) * slice_bytes_;
    if (begin < held_begin_) {
      ++restarts_;
      restart();
    }
    const std::uint64_t decoded = held_begin_ + held_.size();
    if (begin >= decoded) {
      held_.clear();
      if (stream_->skip(begin - decoded) != begin - decoded) ended_short();
    } else {
      held_.erase(held_.begin(), held_.begin() + std::ptrdiff_t(begin - held_begin_));
    }
    held_begin_ = begin;
    // Grown as bytes arrive, so a stream far shorter than its header says fails before a large
    // buffer is allocated.
    held_.reserve(std::size_t(std::min(end - held_begin_, kDirectBytes)));
    while (held_begin_ + held_.size() < end) {
      const std::size_t at = held_.size();
      const auto want = std::size_t(std::min<std::uint64_t>(end - held_begin_ - at, kDecodeChunk));
      held_.resize(at + want);
      const std::size_t got = stream_->read(held_.data() + at, want);
      held_.resize(at + got);
      if (got == 0) ended_short();
    }
    if (end == volume_.declared.bytes) check_stream_ends();
  }

  // After a large read (a whole volume) only its last slices stay held, for a next read that
  // overlaps it (bricks with overlap), so the memory held is not a second copy of the read.
  void keep_tail() {
    const std::uint64_t keep = kept_bytes();
    if (held_.size() <= keep) return;
    std::vector<std::byte> tail(held_.end() - std::ptrdiff_t(keep), held_.end());
    held_begin_ += held_.size() - keep;
    held_.swap(tail);
  }

  // The stream must end where the header says: one more byte means it holds more.
  void check_stream_ends() {
    std::byte extra{};
    if (stream_->read(&extra, 1) != 0) throw_decodes_to_more(file(), volume_.field, volume_.declared);
  }

  Volume copy_out(const Box& box) const {
    const VolumeInfo& info = volume_.info;
    Volume result(box.size(), info.dtype, info.spacing);
    const std::uint64_t sample = dtype_size(info.dtype);
    const auto count = std::uint64_t(volume_.interleave.count), index = std::uint64_t(volume_.interleave.index);
    std::byte* out = result.bytes();
    for (std::int64_t z = box.lo.z; z < box.hi.z; ++z) {
      const std::byte* slice = held_.data() + (volume_.offset + std::uint64_t(z) * slice_bytes_ - held_begin_);
      for (std::int64_t y = box.lo.y; y < box.hi.y; ++y) {
        const std::byte* row = slice + std::uint64_t(y * info.dims.x) * count * sample;
        if (count == 1) {
          const std::uint64_t n = std::uint64_t(box.hi.x - box.lo.x) * sample;
          std::memcpy(out, row + std::uint64_t(box.lo.x) * sample, n);
          out += n;
          continue;
        }
        for (std::int64_t x = box.lo.x; x < box.hi.x; ++x, out += sample)
          std::memcpy(out, row + (std::uint64_t(x) * count + index) * sample, sample);
      }
    }
    const bool swap = volume_.big_endian != (std::endian::native == std::endian::big);
    if (swap) byte_swap(result.bytes(), result.byte_size() / sample, sample);
    return result;
  }

  // Decodes the volume's samples (all interleaved volumes' when they are interleaved) once into
  // an unnamed temporary file and serves every read from its mapping.
  void spill() {
    const std::uint64_t bytes = region_end_ - volume_.offset;
    const std::filesystem::path dir = temp_folder(temp_dir_, file());
    check_temp_space(dir, bytes, file(), volume_.field,
                     fmt::format("decoding the gzip data for random access ({} {} of {})",
                                 volume_.interleave.count > 1 ? "the interleaved volumes" : "the volume",
                                 volume_.info.dims.to_string(), dtype_name(volume_.info.dtype)));
    restart();
    held_.shrink_to_fit();
    if (stream_->skip(volume_.offset) != volume_.offset) ended_short();
    UnnamedTempFile decoded(dir, "strata-" + path_.filename().string());
    ProgressTask task(progress_ ? *progress_ : silent_progress(), "decompress", bytes, "bytes");
    std::vector<std::byte> chunk(std::size_t(std::min(bytes, kDecodeChunk)));
    for (std::uint64_t left = bytes; left > 0;) {
      const std::size_t got = stream_->read(chunk.data(), std::size_t(std::min<std::uint64_t>(left, chunk.size())));
      if (got == 0) ended_short();
      try {
        decoded.write(chunk.data(), got);
      } catch (const Error& e) {
        throw Error(fmt::format("{} (while decoding {})", e.what(), file()));
      }
      left -= got;
      task.advance(got);
    }
    if (region_end_ == volume_.declared.bytes) check_stream_ends();
    stream_.reset();
    auto file_map = std::make_shared<MappedFile>(decoded.descriptor(), fmt::format("{} (decoded)", file()));
    mapped_ = make_mapped_source(std::move(file_map), 0, volume_.info, volume_.big_endian, path_, volume_.field,
                                 volume_.interleave);
  }

  std::shared_ptr<MappedFile> compressed_;
  std::uint64_t start_;
  GzipVolume volume_;
  std::filesystem::path path_;
  std::optional<std::filesystem::path> temp_dir_;  // ReadOptions::temp_dir: TMPDIR is looked up when needed
  ProgressSink* progress_;
  std::uint64_t slice_bytes_;  // decoded bytes per slice (of every interleaved volume)
  std::uint64_t region_end_ = 0;

  std::mutex mutex_;
  std::unique_ptr<GzipStream> stream_;
  std::vector<std::byte> held_;    // decoded bytes [held_begin_, held_begin_ + size) of the stream
  std::uint64_t held_begin_ = 0;
  int restarts_ = 0;
  std::unique_ptr<VolumeSource> mapped_;  // after spill()
};

}  // namespace

std::unique_ptr<VolumeSource> make_gzip_source(std::shared_ptr<MappedFile> compressed, std::uint64_t start,
                                               GzipVolume volume, std::filesystem::path path,
                                               const ReadOptions& options) {
  return std::make_unique<GzipSource>(std::move(compressed), start, std::move(volume), std::move(path), options);
}

}  // namespace strata::io::detail
