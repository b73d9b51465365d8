#pragma once
/// @file
/// @brief A file on a web server or object store read with HTTP range requests (libcurl): the
/// first `head_bytes` when it opens (which also tells the file's size), then exactly the ranges
/// asked for, kept in a bounded LRU cache. Transient failures (connection refused or reset,
/// timeouts, a stalled or cut-short answer, 5xx, 429) are retried with exponential backoff; a
/// server that ignores ranges (200 instead of 206), 4xx answers and persistent failures raise an
/// Error naming the URL, the range and what went wrong. S3 public or presigned URLs are plain
/// HTTPS URLs and need nothing else.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "strata/io/byte_source.hpp"

namespace strata::io {

/// @brief Limits of an HttpSource.
struct HttpOptions {
  int attempts = 5;                            // tries per request, the first included (>= 1)
  int backoff_ms = 200;                        // wait before the first retry; doubles after each
  int connect_timeout_ms = 10000;              // to open a connection
  int stall_timeout_s = 30;                    // an answer that receives nothing for this long fails
  std::uint64_t head_bytes = 64 << 10;         // fetched when the source opens
  std::uint64_t cache_bytes = 256ull << 20;    // bytes the range cache holds at most
  std::uint64_t cache_entries = 4096;          // ranges the cache holds at most
  std::uint64_t coalesce_gap = 16 << 10;       // prefetch merges ranges this close
  std::uint64_t coalesce_limit = 16ull << 20;  // into requests of at most this many bytes
  int prefetch_connections = 4;                // requests a prefetch keeps in flight at once

  /// @brief The defaults, overridden by the environment: STRATA_HTTP_ATTEMPTS,
  /// STRATA_HTTP_BACKOFF_MS, STRATA_HTTP_TIMEOUT_S (stall timeout), STRATA_HTTP_CACHE_MB.
  /// A value that is not a positive integer is ignored.
  static HttpOptions from_environment();
};

/// @brief Opens `url` (http:// or https://): fetches its first options.head_bytes with one range
/// request and reads the file's size from the answer's Content-Range. Throws Error naming the
/// URL when the server refuses, ignores ranges or gives no size.
std::shared_ptr<const ByteSource> open_http_source(const std::string& url, const HttpOptions& options);

/// @brief The whole object at `url`, fetched with one plain GET (retried like a range request
/// while failures look transient), or nothing when the server answers 404 or 410: how Zarr keys
/// on a web server are read, where a missing chunk is the fill value. Throws Error naming the URL
/// on any other answer, and when the object is longer than `max_bytes`.
std::optional<std::vector<std::byte>> fetch_http_object(const std::string& url, const HttpOptions& options,
                                                        std::uint64_t max_bytes);

/// @brief The source of `url` while some caller holds it open, else a new one (options from
/// the environment): commands open a file more than once (`info` checks it with its codec's
/// reader, then reports), and each would otherwise fetch the header and index again.
std::shared_ptr<const ByteSource> shared_http_source(const std::string& url);

/// @brief What reading `url` has cost so far while some caller holds it open (for reports of
/// commands that do not reach the reader), else nothing.
std::optional<TransferStats> transfer_stats_of(const std::string& url);

}  // namespace strata::io
