// The HTTP store: keys are URLs below the root, read whole and kept in a bounded cache, so that
// size() and the read() after it (the chunk reader asks both) cost one request.
#include "io/zarr/http_store.hpp"

#include <mutex>
#include <set>

#include <fmt/format.h>

#include "io/lru_cache.hpp"
#include "strata/core/error.hpp"
#include "strata/io/http_source.hpp"

namespace strata::io::detail {

namespace {

// Objects read whole at most this large: a chunk of a few MiB is the norm; a sharded array's
// shards are fetched whole too (HTTP has no listing to find their sizes by range).
constexpr std::uint64_t kMaxObjectBytes = 1ull << 30;
constexpr std::size_t kCacheBytes = 64u << 20;

using Bytes = std::vector<std::byte>;

class HttpStore final : public ZarrStore {
 public:
  explicit HttpStore(std::string root) : root_(std::move(root)), options_(HttpOptions::from_environment()) {}

  std::optional<std::uint64_t> size(const std::string& key) const override {
    const auto bytes = object(key);
    return bytes ? std::optional(std::uint64_t(bytes->size())) : std::nullopt;
  }

  std::vector<std::byte> read(const std::string& key, std::uint64_t offset, std::uint64_t length,
                              const std::string& field) const override {
    const auto bytes = object(key);
    if (!bytes) throw FormatError(name(key), field, "not found on the server (HTTP 404)");
    if (offset > bytes->size() || length > bytes->size() - offset)
      throw FormatError(name(key), field,
                        fmt::format("bytes {}..+{} are outside the object of {} bytes", offset, length, bytes->size()));
    return Bytes(bytes->begin() + std::ptrdiff_t(offset), bytes->begin() + std::ptrdiff_t(offset + length));
  }

  // A web server has no listing: groups are found through their metadata (OME-Zarr multiscales).
  std::vector<std::string> children(const std::string&) const override { return {}; }
  bool listable() const override { return false; }

  std::string name(const std::string& key) const override { return key.empty() ? root_ : root_ + "/" + key; }

 private:
  // The value of `key`, from the cache or the server; null when the server has none.
  std::shared_ptr<const Bytes> object(const std::string& key) const {
    {
      std::lock_guard lock(mutex_);
      if (missing_.contains(key)) return nullptr;
      if (auto hit = cache_.find(key)) return hit;
    }
    std::optional<Bytes> fetched = fetch_http_object(name(key), options_, kMaxObjectBytes);
    std::lock_guard lock(mutex_);
    if (!fetched) {
      missing_.insert(key);
      return nullptr;
    }
    auto bytes = std::make_shared<const Bytes>(std::move(*fetched));
    cache_.insert(key, bytes, bytes->size());
    return bytes;
  }

  std::string root_;
  HttpOptions options_;
  mutable std::mutex mutex_;
  mutable LruCache<std::string, Bytes> cache_{kCacheBytes};
  mutable std::set<std::string> missing_;
};

}  // namespace

std::shared_ptr<const ZarrStore> open_http_store(const std::string& url) {
  std::string root = url;
  while (root.ends_with('/')) root.pop_back();
  return std::make_shared<HttpStore>(std::move(root));
}

}  // namespace strata::io::detail
