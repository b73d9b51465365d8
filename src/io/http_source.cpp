#include "strata/io/http_source.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <curl/curl.h>
#include <fmt/format.h>

#include "range_cache.hpp"
#include "strata/core/error.hpp"

namespace strata::io {

namespace {

// Retries wait at most this long each, however many there are.
constexpr int kMaxBackoffMs = 5000;
constexpr long kMaxRedirects = 5;

void init_curl() {
  static std::once_flag once;
  std::call_once(once, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
}

// What one request brought back.
struct Response {
  CURLcode code = CURLE_OK;
  std::string curl_error;
  long status = 0;                         // of the last status line seen (a redirect's is followed by another)
  std::optional<ByteRange> content_range;  // from Content-Range: bytes first-last/total
  std::optional<std::uint64_t> total;
  std::vector<std::byte> body;
  std::uint64_t expected = 0;  // the bytes asked for (whole: at most): a longer body is cut off
  bool whole = false;          // a plain GET of a whole object, not a range request
  bool ignored_range = false;  // a 200 answer to a range request, aborted at its first bytes
  bool too_large = false;      // a whole object longer than `expected`, aborted
};

// "Content-Range: bytes 0-65535/1234567" (any case, any spacing after the colon).
void parse_content_range(std::string_view line, Response& r) {
  constexpr std::string_view kName = "content-range:";
  if (line.size() < kName.size()) return;
  for (std::size_t i = 0; i < kName.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(line[i])) != kName[i]) return;
  unsigned long long first = 0, last = 0, total = 0;
  const std::string value(line.substr(kName.size()));
  if (std::sscanf(value.c_str(), " bytes %llu-%llu/%llu", &first, &last, &total) == 3 && last >= first) {
    r.content_range = ByteRange{first, last - first + 1};
    r.total = total;
  }
}

std::size_t on_header(char* data, std::size_t size, std::size_t count, void* user) {
  auto& r = *static_cast<Response*>(user);
  const std::string_view line(data, size * count);
  if (line.starts_with("HTTP/")) {  // a new answer (after a redirect): forget the last one's
    r.content_range.reset();
    r.total.reset();
    const std::size_t space = line.find(' ');
    r.status = space == std::string_view::npos ? 0 : std::atol(std::string(line.substr(space + 1, 3)).c_str());
  }
  parse_content_range(line, r);
  return size * count;
}

std::size_t on_body(char* data, std::size_t size, std::size_t count, void* user) {
  auto& r = *static_cast<Response*>(user);
  const std::size_t n = size * count;
  const auto* bytes = reinterpret_cast<const std::byte*>(data);
  if (r.whole) {
    if (r.status != 200) return n;  // an error page: the status says it all
    if (r.body.size() + n > r.expected) {
      r.too_large = true;
      return 0;
    }
    r.body.insert(r.body.end(), bytes, bytes + n);
    return n;
  }
  // A 200 answer is the whole file: stop it at its first bytes rather than download it.
  if (r.status == 200) {
    r.ignored_range = true;
    return 0;
  }
  if (r.status != 206) return n;                 // an error page: the status says it all
  if (r.body.size() + n > r.expected) return 0;  // more than asked for: refuse the rest
  r.body.insert(r.body.end(), bytes, bytes + n);
  return n;
}

std::string status_text(long status) {
  switch (status) {
    case 400: return "400 Bad Request";
    case 401: return "401 Unauthorized";
    case 403: return "403 Forbidden (a private object, or an expired or wrongly signed presigned URL)";
    case 404: return "404 Not Found";
    case 410: return "410 Gone";
    case 416: return "416 Range Not Satisfiable (the file on the server is shorter than the range asked for)";
    default: return std::to_string(status);
  }
}

bool transient_curl_error(CURLcode code) {
  switch (code) {
    case CURLE_COULDNT_CONNECT:
    case CURLE_OPERATION_TIMEDOUT:
    case CURLE_PARTIAL_FILE:
    case CURLE_RECV_ERROR:
    case CURLE_SEND_ERROR:
    case CURLE_GOT_NOTHING:
    case CURLE_SSL_CONNECT_ERROR:
    case CURLE_HTTP2:
    case CURLE_HTTP2_STREAM: return true;
    default: return false;
  }
}

bool transient_status(long status) { return status == 408 || status == 429 || status >= 500; }

// An Error for `url`, the bytes asked for and the problem.
Error fetch_error(const std::string& url, ByteRange range, const std::string& problem) {
  return Error(fmt::format("{}: bytes {}-{}: {}", url, range.offset, range.offset + range.size - 1, problem));
}

std::optional<int> environment_int(const char* name) {
  const char* text = std::getenv(name);
  if (!text) return std::nullopt;
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || value <= 0 || value > 1'000'000) return std::nullopt;
  return int(value);
}

// Curl easy handles kept for reuse (each keeps its connection alive); one per concurrent
// request, as the decoders fetch from several threads.
class HandlePool {
 public:
  ~HandlePool() {
    for (CURL* h : free_) curl_easy_cleanup(h);
  }
  CURL* take() {
    {
      std::lock_guard lock(mutex_);
      if (!free_.empty()) {
        CURL* h = free_.back();
        free_.pop_back();
        return h;
      }
    }
    CURL* h = curl_easy_init();
    if (!h) throw Error("cannot create an HTTP client handle (libcurl)");
    return h;
  }
  void give_back(CURL* h) {
    std::lock_guard lock(mutex_);
    free_.push_back(h);
  }

 private:
  std::mutex mutex_;
  std::vector<CURL*> free_;
};

// Sends one GET of `url` (of `range` when given) on a pooled handle and fills `r` with the answer.
void perform(HandlePool& handles, const std::string& url, const ByteRange* range, const HttpOptions& options,
             Response& r) {
  const std::string bytes = range ? fmt::format("{}-{}", range->offset, range->offset + range->size - 1) : "";
  char error[CURL_ERROR_SIZE] = {};
  CURL* h = handles.take();
  curl_easy_reset(h);
  curl_easy_setopt(h, CURLOPT_URL, url.c_str());
  if (range) curl_easy_setopt(h, CURLOPT_RANGE, bytes.c_str());
  curl_easy_setopt(h, CURLOPT_NOSIGNAL, 1L);  // threads: no SIGALRM for timeouts
  curl_easy_setopt(h, CURLOPT_FOLLOWLOCATION, 1L);
  curl_easy_setopt(h, CURLOPT_MAXREDIRS, kMaxRedirects);
  curl_easy_setopt(h, CURLOPT_CONNECTTIMEOUT_MS, long(options.connect_timeout_ms));
  curl_easy_setopt(h, CURLOPT_LOW_SPEED_LIMIT, 1L);
  curl_easy_setopt(h, CURLOPT_LOW_SPEED_TIME, long(options.stall_timeout_s));
  curl_easy_setopt(h, CURLOPT_HEADERFUNCTION, on_header);
  curl_easy_setopt(h, CURLOPT_HEADERDATA, &r);
  curl_easy_setopt(h, CURLOPT_WRITEFUNCTION, on_body);
  curl_easy_setopt(h, CURLOPT_WRITEDATA, &r);
  curl_easy_setopt(h, CURLOPT_ERRORBUFFER, error);
  curl_easy_setopt(h, CURLOPT_USERAGENT, "strata");
  r.code = curl_easy_perform(h);
  long status = 0;
  if (curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &status) == CURLE_OK && status != 0) r.status = status;
  curl_easy_setopt(h, CURLOPT_ERRORBUFFER, nullptr);
  handles.give_back(h);
  r.curl_error = error[0] ? error : curl_easy_strerror(r.code);
}

// Waits before retry `attempt` (2, 3, ...): backoff_ms, doubling, at most kMaxBackoffMs.
void wait_before_retry(const HttpOptions& options, int attempt) {
  const int wait = std::min(kMaxBackoffMs, options.backoff_ms << std::min(attempt - 2, 16));
  std::this_thread::sleep_for(std::chrono::milliseconds(wait));
}

class HttpSource final : public ByteSource {
 public:
  HttpSource(std::string url, const HttpOptions& options)
      : url_(std::move(url)), options_(options), cache_(options.cache_bytes, options.cache_entries) {
    init_curl();
    Response r = fetch({0, std::max<std::uint64_t>(options_.head_bytes, 1)}, true);
    size_ = *r.total;
    head_ = keep(std::move(r.body));
  }
  const std::string& name() const override { return url_; }
  std::uint64_t size() const override { return size_; }
  bool remote() const override { return true; }

  SharedBytes read(std::uint64_t offset, std::uint64_t size) const override {
    if (offset + size <= head_.size()) return head_.subrange(offset, size);
    if (auto hit = cache_.find(offset, size)) {
      ++stats_.cache_hits;
      return *hit;
    }
    SharedBytes bytes = fetch_shared({offset, size});
    cache_.insert(offset, bytes);
    return bytes;
  }

  // The runs are fetched on up to prefetch_connections threads at once, so a box costs a few
  // round trips however many rows of bricks it spans. Stops at half the cache: more would evict
  // the first runs before they are read (the rest is fetched when read).
  void prefetch(std::span<const ByteRange> ranges) const override {
    std::vector<ByteRange> runs = missing_runs(ranges);
    std::uint64_t total = 0;
    const auto past_budget = std::find_if(runs.begin(), runs.end(), [&](const ByteRange& r) {
      total += r.size;
      return total > options_.cache_bytes / 2;
    });
    runs.erase(past_budget, runs.end());
    std::atomic<std::size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    const auto work = [&] {
      for (std::size_t i; (i = next++) < runs.size();) try {
          cache_.insert(runs[i].offset, fetch_shared(runs[i]));
        } catch (...) {
          std::lock_guard lock(failure_mutex);
          if (!failure) failure = std::current_exception();
        }
    };
    std::vector<std::jthread> threads;
    const std::size_t count =
        std::min<std::size_t>(runs.size(), std::size_t(std::max(1, options_.prefetch_connections)));
    for (std::size_t t = 1; t < count; ++t) threads.emplace_back(work);
    work();
    threads.clear();  // joins
    if (failure) std::rethrow_exception(failure);
  }

  TransferStats transfer_stats() const override {
    return {stats_.bytes_fetched.load(), stats_.requests.load(), stats_.retries.load(), stats_.cache_hits.load()};
  }

 private:
  struct Counters {
    std::atomic<std::uint64_t> bytes_fetched{0}, requests{0}, retries{0}, cache_hits{0};
  };

  // The ranges not yet cached, in file order, neighbours closer than coalesce_gap merged into
  // one request of at most coalesce_limit bytes (the gap bytes cost less than a round trip).
  std::vector<ByteRange> missing_runs(std::span<const ByteRange> ranges) const {
    std::vector<ByteRange> wanted;
    for (const ByteRange& r : ranges)
      if (r.size != 0 && r.offset + r.size > head_.size() && !cache_.find(r.offset, r.size)) wanted.push_back(r);
    std::sort(wanted.begin(), wanted.end(), [](const ByteRange& a, const ByteRange& b) { return a.offset < b.offset; });
    std::vector<ByteRange> runs;
    for (const ByteRange& r : wanted) {
      if (!runs.empty()) {
        ByteRange& last = runs.back();
        const std::uint64_t end = last.offset + last.size, merged_end = std::max(end, r.offset + r.size);
        if (r.offset <= end + options_.coalesce_gap && merged_end - last.offset <= options_.coalesce_limit) {
          last.size = merged_end - last.offset;
          continue;
        }
      }
      runs.push_back(r);
    }
    return runs;
  }

  static SharedBytes keep(std::vector<std::byte> bytes) {
    auto body = std::make_shared<std::vector<std::byte>>(std::move(bytes));
    return SharedBytes(body, *body);
  }

  SharedBytes fetch_shared(ByteRange range) const { return keep(fetch(range, false).body); }

  // One range, retried with backoff while failures look transient. `opening`: the first request,
  // which learns the size (and may ask beyond the end of a small file).
  Response fetch(ByteRange range, bool opening) const {
    std::string last_problem;
    for (int attempt = 1; attempt <= options_.attempts; ++attempt) {
      if (attempt > 1) {
        ++stats_.retries;
        wait_before_retry(options_, attempt);
      }
      Response r = request(range);
      if (auto problem = transient_problem(r, range)) {
        last_problem = *problem;
        continue;
      }
      check_answer(r, range, opening);
      return r;
    }
    throw fetch_error(url_, range, fmt::format("{} (failed {} times; giving up)", last_problem, options_.attempts));
  }

  Response request(ByteRange range) const {
    Response r;
    r.expected = range.size;
    r.body.reserve(std::size_t(std::min<std::uint64_t>(range.size, 64ull << 20)));
    perform(handles_, url_, &range, options_, r);
    ++stats_.requests;
    stats_.bytes_fetched += r.body.size();
    return r;
  }

  // Why `r` is worth another try, or nothing when it is an answer (good or definitely bad).
  std::optional<std::string> transient_problem(const Response& r, ByteRange range) const {
    if (r.ignored_range) return std::nullopt;
    if (r.code == CURLE_WRITE_ERROR) return std::nullopt;  // we stopped a longer answer: checked below
    if (r.code != CURLE_OK) {
      if (transient_curl_error(r.code)) return r.curl_error;
      throw fetch_error(url_, range, r.curl_error);
    }
    if (transient_status(r.status)) return fmt::format("HTTP {}", r.status);
    if (r.status == 206 && r.content_range && r.body.size() < r.content_range->size)
      return fmt::format("the answer ended after {} of its {} bytes", r.body.size(), r.content_range->size);
    return std::nullopt;
  }

  // Throws unless `r` is a 206 answer holding exactly `range` of a file of the known size (when
  // opening: as much of `range` as the file has, which gives the size).
  void check_answer(const Response& r, ByteRange range, bool opening) const {
    if (r.ignored_range || r.status == 200)
      throw fetch_error(url_, range,
                        "the server answered 200 with the whole file instead of 206 Partial Content: it does not "
                        "support HTTP range requests, which reading a remote .strata file needs");
    if (r.status != 206) throw fetch_error(url_, range, "HTTP " + status_text(r.status));
    if (!r.content_range || !r.total)
      throw fetch_error(url_, range, "the 206 answer has no Content-Range header of the form bytes first-last/total");
    const std::uint64_t total = *r.total;
    if (!opening && total != size_)
      throw fetch_error(url_, range,
                        fmt::format("the file is now {} bytes, was {} (it changed on the server)", total, size_));
    const std::uint64_t expected = opening ? std::min(range.size, total) : range.size;
    if (r.content_range->offset != range.offset || r.content_range->size != expected || r.body.size() != expected)
      throw fetch_error(
          url_, range,
          fmt::format("the server sent bytes {}-{} ({} bytes of body) of a {}-byte file, expected {} bytes "
                      "from {}",
                      r.content_range->offset, r.content_range->offset + r.content_range->size - 1, r.body.size(),
                      total, expected, range.offset));
  }

  std::string url_;
  HttpOptions options_;
  std::uint64_t size_ = 0;
  SharedBytes head_;
  mutable detail::RangeCache cache_;
  mutable HandlePool handles_;
  mutable Counters stats_;
};

}  // namespace

HttpOptions HttpOptions::from_environment() {
  HttpOptions o;
  if (auto v = environment_int("STRATA_HTTP_ATTEMPTS")) o.attempts = *v;
  if (auto v = environment_int("STRATA_HTTP_BACKOFF_MS")) o.backoff_ms = *v;
  if (auto v = environment_int("STRATA_HTTP_TIMEOUT_S")) o.stall_timeout_s = *v;
  if (auto v = environment_int("STRATA_HTTP_CACHE_MB")) o.cache_bytes = std::uint64_t(*v) << 20;
  return o;
}

std::shared_ptr<const ByteSource> open_http_source(const std::string& url, const HttpOptions& options) {
  if (options.attempts < 1)
    throw ParameterError("attempts", fmt::format("must be at least 1, got {}", options.attempts));
  return std::make_shared<HttpSource>(url, options);
}

namespace {

// Whole objects share one pool of handles (and so their kept-alive connections).
HandlePool& object_handles() {
  static HandlePool pool;
  return pool;
}

}  // namespace

std::optional<std::vector<std::byte>> fetch_http_object(const std::string& url, const HttpOptions& options,
                                                        std::uint64_t max_bytes) {
  init_curl();
  std::string last_problem;
  for (int attempt = 1; attempt <= std::max(1, options.attempts); ++attempt) {
    if (attempt > 1) wait_before_retry(options, attempt);
    Response r;
    r.whole = true;
    r.expected = max_bytes;
    perform(object_handles(), url, nullptr, options, r);
    if (r.too_large)
      throw Error(fmt::format("{}: the object is larger than {} bytes, the most read whole", url, max_bytes));
    if (r.code != CURLE_OK) {
      if (!transient_curl_error(r.code)) throw Error(fmt::format("{}: {}", url, r.curl_error));
      last_problem = r.curl_error;
      continue;
    }
    if (transient_status(r.status)) {
      last_problem = fmt::format("HTTP {}", r.status);
      continue;
    }
    if (r.status == 404 || r.status == 410) return std::nullopt;
    if (r.status != 200) throw Error(fmt::format("{}: HTTP {}", url, status_text(r.status)));
    return std::move(r.body);
  }
  throw Error(fmt::format("{}: {} (failed {} times; giving up)", url, last_problem, options.attempts));
}

namespace {

// The remote sources open now, by URL.
struct OpenSources {
  std::mutex mutex;
  std::map<std::string, std::weak_ptr<const ByteSource>> by_url;
};

OpenSources& open_sources() {
  static OpenSources sources;
  return sources;
}

}  // namespace

std::shared_ptr<const ByteSource> shared_http_source(const std::string& url) {
  OpenSources& open = open_sources();
  std::lock_guard lock(open.mutex);
  if (auto source = open.by_url[url].lock()) return source;
  std::erase_if(open.by_url, [](const auto& entry) { return entry.second.expired(); });
  auto source = open_http_source(url, HttpOptions::from_environment());
  open.by_url[url] = source;
  return source;
}

std::optional<TransferStats> transfer_stats_of(const std::string& url) {
  OpenSources& open = open_sources();
  std::lock_guard lock(open.mutex);
  const auto it = open.by_url.find(url);
  if (it == open.by_url.end()) return std::nullopt;
  const auto source = it->second.lock();
  return source ? std::optional(source->transfer_stats()) : std::nullopt;
}

}  // namespace strata::io
