#pragma once
/// @file
/// @brief Random-access bytes of one file, local or remote. A `.strata` container is read
/// through a ByteSource: a local file is memory-mapped and read without copying; an `http://`
/// or `https://` URL is read with HTTP range requests (io/http_source.hpp). Reads hand out
/// SharedBytes, a span together with what keeps its bytes alive (the mapping, or the buffer a
/// server's answer was stored in), so callers work with spans either way.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>

namespace strata::io {

/// @brief Bytes read from a ByteSource and the owner that keeps them valid. Copies share the
/// owner. A span taken from it is valid while some SharedBytes holding the owner lives, so a
/// temporary cannot be turned into a span (it would dangle once the owner goes).
class SharedBytes {
 public:
  SharedBytes() = default;
  SharedBytes(std::shared_ptr<const void> owner, std::span<const std::byte> bytes)
      : owner_(std::move(owner)), bytes_(bytes) {}
  std::span<const std::byte> span() const& { return bytes_; }
  std::span<const std::byte> span() && = delete;
  operator std::span<const std::byte>() const& { return bytes_; }
  operator std::span<const std::byte>() && = delete;
  auto begin() const& { return bytes_.begin(); }
  auto end() const& { return bytes_.end(); }
  const std::byte* data() const { return bytes_.data(); }
  std::size_t size() const { return bytes_.size(); }
  bool empty() const { return bytes_.empty(); }
  /// @brief Bytes [offset, offset + size) of these (the caller keeps them inside), same owner.
  SharedBytes subrange(std::uint64_t offset, std::uint64_t size) const {
    return {owner_, bytes_.subspan(std::size_t(offset), std::size_t(size))};
  }

 private:
  std::shared_ptr<const void> owner_;
  std::span<const std::byte> bytes_;
};

/// @brief A byte range of a source.
struct ByteRange {
  std::uint64_t offset = 0, size = 0;
};

/// @brief What reading a remote source cost so far (all zero for a local file).
struct TransferStats {
  std::uint64_t bytes_fetched = 0;  // response bytes received, retries included
  std::uint64_t requests = 0;       // HTTP requests sent, retries included
  std::uint64_t retries = 0;        // requests repeated after a transient failure
  std::uint64_t cache_hits = 0;     // reads answered from the range cache
};

/// @brief Random access to the bytes of one file. Every member is thread-safe.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  /// @brief How messages name the source: the path, or the URL.
  virtual const std::string& name() const = 0;
  /// @brief The file's size in bytes.
  virtual std::uint64_t size() const = 0;
  /// @brief Bytes [offset, offset + size), which the caller has checked lie inside size().
  /// Throws Error naming the source when they cannot be read (for a URL: after retries).
  virtual SharedBytes read(std::uint64_t offset, std::uint64_t size) const = 0;
  /// @brief A hint that `ranges` will be read soon: a remote source fetches the missing ones in
  /// as few requests as is cheap; a local one does nothing.
  virtual void prefetch(std::span<const ByteRange> ranges) const { (void)ranges; }
  /// @brief True when reads cross a network (then transfer_stats() counts them).
  virtual bool remote() const { return false; }
  /// @brief What reads cost so far (for a sub-range, its whole file's figures).
  virtual TransferStats transfer_stats() const { return {}; }
};

/// @brief True when `path` is an `http://` or `https://` URL (case-insensitive scheme).
bool is_url(std::string_view path);

/// @brief The source of `path`: for a URL an HTTP range reader (options from the environment,
/// io/http_source.hpp), shared with every caller holding the same URL open, so a file opened
/// twice fetches its header once; otherwise the memory-mapped file. Throws Error naming the
/// path or URL.
std::shared_ptr<const ByteSource> open_byte_source(const std::filesystem::path& path);

/// @brief Bytes [offset, offset + size) of `outer` (which the caller has checked) as a source of
/// their own, named `name`; offsets are relative to `offset`.
std::shared_ptr<const ByteSource> byte_subrange(std::shared_ptr<const ByteSource> outer, std::uint64_t offset,
                                                std::uint64_t size, std::string name);

}  // namespace strata::io
