#include "server/http_wire.hpp"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>

#include <fmt/format.h>

namespace strata::server::wire {

namespace {

constexpr std::size_t kMaxChunkLine = 1024;  // a chunk-size line with its extensions
constexpr std::size_t kMaxEmptyLines = 64;   // CRLFs tolerated before a request line
constexpr std::size_t kGzipFrom = 1024;      // smaller bodies are sent as they are

bool is_tchar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("!#$%&'*+-.^_`|~", c) != nullptr;
}

bool is_token(std::string_view s) { return !s.empty() && std::all_of(s.begin(), s.end(), is_tchar); }

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool same_name(std::string_view a, std::string_view b) { return a.size() == b.size() && lower(a) == lower(b); }

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// Calls `f` on each comma-separated element of a header value, trimmed.
template <class F>
void for_each_element(std::string_view value, F f) {
  while (true) {
    const std::size_t comma = value.find(',');
    f(trim(value.substr(0, comma)));
    if (comma == std::string_view::npos) return;
    value.remove_prefix(comma + 1);
  }
}

// A line without its LF and the CR before it.
std::string_view without_line_end(std::string_view line) {
  if (!line.empty() && line.back() == '\n') line.remove_suffix(1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

// Where the first empty line at or after `from` ends: the line that begins at `from` when
// `at_line_start`, otherwise one that follows a line end found from `from` on. npos when the
// bytes do not hold one yet.
std::size_t empty_line_end(std::string_view s, std::size_t from, bool at_line_start) {
  if (at_line_start) {
    if (s.substr(from, 1) == "\n") return from + 1;
    if (s.substr(from, 2) == "\r\n") return from + 2;
  }
  for (std::size_t i = s.find('\n', from); i != std::string_view::npos; i = s.find('\n', i + 1)) {
    if (i + 1 < s.size() && s[i + 1] == '\n') return i + 2;
    if (i + 2 < s.size() && s[i + 1] == '\r' && s[i + 2] == '\n') return i + 3;
  }
  return std::string_view::npos;
}

// A Content-Length element: decimal digits only, at most 18 of them (no sign, no spaces).
std::optional<std::size_t> parse_length(std::string_view s) {
  if (s.empty() || s.size() > 18 || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  std::size_t n = 0;
  for (char c : s) n = n * 10 + std::size_t(c - '0');
  return n;
}

// True when an Accept-Encoding value allows gzip ("gzip" or "*" with a q-value above 0).
bool allows_gzip(std::string_view value) {
  bool allowed = false;
  for_each_element(value, [&](std::string_view element) {
    const std::size_t semicolon = element.find(';');
    const std::string coding = lower(trim(element.substr(0, semicolon)));
    if (coding != "gzip" && coding != "x-gzip" && coding != "*") return;
    double q = 1;
    if (semicolon != std::string_view::npos) {
      const std::string parameter = lower(trim(element.substr(semicolon + 1)));
      if (parameter.starts_with("q=")) q = std::strtod(parameter.c_str() + 2, nullptr);
    }
    if (coding == "*" && allowed) return;  // an explicit gzip entry decides
    allowed = q > 0;
  });
  return allowed;
}

bool compressible(std::string_view content_type) {
  const std::string type = lower(trim(content_type.substr(0, content_type.find(';'))));
  return type.starts_with("text/") || type == "application/json" || type == "application/javascript" ||
         type == "image/svg+xml" || type == "application/xml";
}

std::optional<std::string> gzip(const std::string& data) {
  if (data.size() > (1u << 30)) return std::nullopt;
  z_stream z{};
  if (deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) return std::nullopt;
  std::string out(deflateBound(&z, uLong(data.size())) + 32, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = uInt(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  const int result = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (result != Z_STREAM_END) return std::nullopt;
  return out;
}

bool valid_header_line(std::string_view name, std::string_view value) {
  return is_token(name) && std::none_of(value.begin(), value.end(), [](char c) { return c == '\r' || c == '\n' || c == '\0'; });
}

}  // namespace

RequestReader::RequestReader(Limits limits) : limits_(limits) {}

void RequestReader::feed(std::string_view bytes) { in_.append(bytes); }

RequestReader::Phase RequestReader::phase() const {
  if (body_at_ != 0) return Phase::body;
  return buffered() == 0 ? Phase::idle : Phase::head;
}

RequestReader::Status RequestReader::fail(int status, std::string message) {
  error_status_ = status;
  error_message_ = std::move(message);
  return status_ = Status::failed;
}

bool RequestReader::take_continue() {
  if (!expect_continue_ || body_at_ == 0 || status_ != Status::incomplete) return false;
  expect_continue_ = false;
  return true;
}

RequestReader::Status RequestReader::advance() {
  if (status_ != Status::incomplete) return status_;
  if (body_at_ == 0) {
    // Empty lines before a request line are skipped (RFC 9112, 2.2), a few of them.
    while (start_ < in_.size() && (in_[start_] == '\n' || (in_[start_] == '\r' && start_ + 1 < in_.size() && in_[start_ + 1] == '\n'))) {
      start_ += in_[start_] == '\n' ? 1 : 2;
      if (start_ > kMaxEmptyLines) return fail(400, "empty lines instead of a request line");
    }
    const std::size_t end = empty_line_end(in_, std::max(start_, scanned_), false);
    if (end == std::string::npos ? buffered() > limits_.max_head_bytes : end - start_ > limits_.max_head_bytes) {
      const std::size_t line_end = in_.find('\n', start_);
      if (line_end == std::string::npos || line_end - start_ >= limits_.max_head_bytes)
        return fail(414, fmt::format("request line longer than {} bytes", limits_.max_head_bytes));
      return fail(431, fmt::format("request head longer than {} bytes", limits_.max_head_bytes));
    }
    if (end == std::string::npos) {
      scanned_ = std::max(start_, in_.size() >= 2 ? in_.size() - 2 : 0);  // a line end may be split
      return Status::incomplete;
    }
    if (parse_head(std::string_view(in_).substr(start_, end - start_)) == Status::failed) return Status::failed;
    body_at_ = chunk_at_ = end;
    if (!chunked_ && content_length_ > limits_.max_body_bytes)
      return fail(413, fmt::format("request body of {} bytes; at most {} are accepted", content_length_, limits_.max_body_bytes));
  }
  if (chunked_) {
    if (read_chunks() != Status::complete) return status_;
  } else {
    if (in_.size() - body_at_ < content_length_) return Status::incomplete;
    body_.assign(in_, body_at_, content_length_);
    end_ = body_at_ + content_length_;
  }
  request_.request = make_request(std::move(request_.request.method), target_, std::move(body_));
  return status_ = Status::complete;
}

RequestReader::Status RequestReader::parse_head(std::string_view head) {
  std::size_t at = 0;
  const auto next_line = [&] {
    const std::size_t newline = head.find('\n', at);
    const std::string_view line = without_line_end(head.substr(at, newline - at + 1));
    at = newline + 1;
    return line;
  };
  // Request line: method SP target SP version, single spaces.
  const std::string_view line = next_line();
  const std::size_t sp1 = line.find(' '), sp2 = sp1 == std::string_view::npos ? sp1 : line.find(' ', sp1 + 1);
  if (sp2 == std::string_view::npos || line.find(' ', sp2 + 1) != std::string_view::npos)
    return fail(400, "malformed request line (expected METHOD TARGET HTTP/1.1)");
  const std::string_view method = line.substr(0, sp1), target = line.substr(sp1 + 1, sp2 - sp1 - 1),
                         version = line.substr(sp2 + 1);
  if (!is_token(method)) return fail(400, "malformed method");
  if (target.empty() || std::any_of(target.begin(), target.end(), [](char c) {
        return static_cast<unsigned char>(c) <= 0x20 || c == 0x7f;
      }))
    return fail(400, "malformed request target");
  const bool digits = version.size() == 8 && version.starts_with("HTTP/") &&
                      std::isdigit(static_cast<unsigned char>(version[5])) && version[6] == '.' &&
                      std::isdigit(static_cast<unsigned char>(version[7]));
  if (!digits) return fail(400, "malformed HTTP version");
  if (version != "HTTP/1.1" && version != "HTTP/1.0") return fail(505, "only HTTP/1.0 and HTTP/1.1 are spoken here");
  const bool http10 = version == "HTTP/1.0";

  // Header lines.
  std::optional<std::size_t> length;
  std::string transfer_coding;
  bool has_transfer_encoding = false, close = false, keep_alive = false;
  int hosts = 0;
  for (std::size_t count = 0;; ++count) {
    const std::string_view h = next_line();
    if (h.empty()) break;
    if (count == limits_.max_headers) return fail(431, fmt::format("more than {} header lines", limits_.max_headers));
    if (h.front() == ' ' || h.front() == '\t') return fail(400, "folded header line");
    const std::size_t colon = h.find(':');
    const std::string_view name = h.substr(0, colon);
    if (colon == std::string_view::npos || !is_token(name))
      return fail(400, "malformed header line (expected Name: value, no space before the colon)");
    const std::string_view value = trim(h.substr(colon + 1));
    if (std::any_of(value.begin(), value.end(), [](char c) { return (c >= 0 && c < 0x20 && c != '\t') || c == 0x7f; }))
      return fail(400, "control character in header " + std::string(name));
    const std::string key = lower(name);
    if (key == "content-length") {
      bool valid = true;
      for_each_element(value, [&](std::string_view element) {
        const auto n = parse_length(element);
        if (!n || (length && *length != *n)) valid = false;
        else length = n;
      });
      if (!valid) return fail(400, "Content-Length: one decimal length expected (values differ or are malformed)");
    } else if (key == "transfer-encoding") {
      has_transfer_encoding = true;
      for_each_element(value, [&](std::string_view element) {
        if (element.empty()) return;
        if (!transfer_coding.empty()) transfer_coding += ',';
        transfer_coding += lower(element);
      });
    } else if (key == "connection") {
      for_each_element(value, [&](std::string_view element) {
        const std::string option = lower(element);
        close = close || option == "close";
        keep_alive = keep_alive || option == "keep-alive";
      });
    } else if (key == "expect") {
      if (lower(value) != "100-continue") return fail(417, "unsupported expectation: " + std::string(value));
      expect_continue_ = true;
    } else if (key == "accept-encoding") {
      request_.accepts_gzip = allows_gzip(value);
    } else if (key == "host") {
      if (++hosts > 1) return fail(400, "more than one Host header");
    }
  }
  if (has_transfer_encoding) {
    if (length) return fail(400, "Content-Length beside Transfer-Encoding");
    if (http10) return fail(400, "Transfer-Encoding in an HTTP/1.0 request");
    if (transfer_coding != "chunked") return fail(501, "unsupported Transfer-Encoding: " + transfer_coding + " (only chunked)");
    chunked_ = true;
  }
  content_length_ = length.value_or(0);

  // The target: origin-form, absolute-form (the path and query kept) or "*" for OPTIONS.
  if (target == "*") {
    if (method != "OPTIONS") return fail(400, "the target * is for OPTIONS only");
    target_ = "*";
  } else if (target.front() == '/') {
    target_ = target;
  } else {
    const std::string scheme = lower(target.substr(0, std::min<std::size_t>(target.size(), 8)));
    const std::size_t authority = scheme.starts_with("http://") ? 7 : scheme.starts_with("https://") ? 8 : 0;
    if (authority == 0) return fail(400, "malformed request target (expected /path)");
    const std::size_t path = target.find_first_of("/?", authority);
    if (path == std::string_view::npos || target[path] == '?') target_ = "/";
    if (path != std::string_view::npos) target_.append(target.substr(path));
  }
  request_.request.method = std::string(method);
  request_.head = method == "HEAD";
  request_.keep_alive = http10 ? keep_alive && !close : !close;
  return Status::incomplete;
}

RequestReader::Status RequestReader::read_chunks() {
  while (true) {
    const std::size_t newline = in_.find('\n', chunk_at_);
    if (newline == std::string::npos) {
      if (in_.size() - chunk_at_ > kMaxChunkLine) return fail(400, "chunk-size line too long");
      return Status::incomplete;
    }
    if (newline - chunk_at_ > kMaxChunkLine) return fail(400, "chunk-size line too long");
    const std::string_view line = without_line_end(std::string_view(in_).substr(chunk_at_, newline - chunk_at_ + 1));
    std::size_t digits = 0, size = 0;
    while (digits < line.size() && std::isxdigit(static_cast<unsigned char>(line[digits]))) {
      if (digits == 15) return fail(400, "chunk size too large");
      const char c = char(std::tolower(static_cast<unsigned char>(line[digits])));
      size = size * 16 + std::size_t(c <= '9' ? c - '0' : c - 'a' + 10);
      ++digits;
    }
    const std::string_view rest = trim(line.substr(digits));
    if (digits == 0 || (!rest.empty() && rest.front() != ';')) return fail(400, "malformed chunk-size line");
    if (size > limits_.max_body_bytes - body_.size())
      return fail(413, fmt::format("request body above {} bytes", limits_.max_body_bytes));
    const std::size_t data = newline + 1;
    if (size == 0) {  // the last chunk, then trailer lines (ignored) and an empty line
      const std::size_t end = empty_line_end(in_, data, true);
      if ((end == std::string::npos ? in_.size() : end) - data > limits_.max_head_bytes)
        return fail(431, "chunked trailer too long");
      if (end == std::string::npos) return Status::incomplete;
      end_ = end;
      return Status::complete;
    }
    if (in_.size() < data + size + 1) return Status::incomplete;
    std::size_t after = data + size;
    if (in_[after] == '\r') {
      if (in_.size() < after + 2) return Status::incomplete;
      ++after;
    }
    if (in_[after] != '\n') return fail(400, "chunk data longer than its size");
    body_.append(in_, data, size);
    chunk_at_ = after + 1;
    // Chunk lines may be long and chunks short: the framing may not cost more than the body may.
    if (chunk_at_ - body_at_ - body_.size() > limits_.max_body_bytes + kMaxChunkLine)
      return fail(413, "chunked body with too much framing");
  }
}

Request RequestReader::take() {
  Request r = std::move(request_);
  in_.erase(0, end_);
  start_ = scanned_ = body_at_ = chunk_at_ = end_ = content_length_ = 0;
  chunked_ = expect_continue_ = false;
  body_.clear();
  target_.clear();
  request_ = {};
  status_ = Status::incomplete;
  return r;
}

std::string_view reason_phrase(int status) {
  switch (status) {
    case 100: return "Continue";
    case 200: return "OK";
    case 201: return "Created";
    case 204: return "No Content";
    case 206: return "Partial Content";
    case 301: return "Moved Permanently";
    case 302: return "Found";
    case 304: return "Not Modified";
    case 400: return "Bad Request";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 408: return "Request Timeout";
    case 409: return "Conflict";
    case 411: return "Length Required";
    case 413: return "Content Too Large";
    case 414: return "URI Too Long";
    case 415: return "Unsupported Media Type";
    case 416: return "Range Not Satisfiable";
    case 417: return "Expectation Failed";
    case 422: return "Unprocessable Content";
    case 429: return "Too Many Requests";
    case 431: return "Request Header Fields Too Large";
    case 500: return "Internal Server Error";
    case 501: return "Not Implemented";
    case 503: return "Service Unavailable";
    case 505: return "HTTP Version Not Supported";
    default: return "Unknown";
  }
}

std::string write_response(const HttpResponse& r, const Framing& framing) {
  const bool bodiless = (r.status >= 100 && r.status < 200) || r.status == 204 || r.status == 304;
  const bool encoded = r.header("Content-Encoding").has_value();
  std::optional<std::string> zipped;
  if (!bodiless && !framing.head && framing.accepts_gzip && !encoded && r.body.size() >= kGzipFrom &&
      compressible(r.content_type)) {
    zipped = gzip(r.body);
    if (zipped && zipped->size() >= r.body.size()) zipped.reset();
  }
  const std::string& body = zipped ? *zipped : r.body;
  std::string out = fmt::format("HTTP/1.1 {} {}\r\n", r.status, reason_phrase(r.status));
  for (const auto& [name, value] : r.headers) {
    if (!valid_header_line(name, value) || same_name(name, "Content-Length") || same_name(name, "Transfer-Encoding") ||
        same_name(name, "Connection") || same_name(name, "Content-Type"))
      continue;
    out += fmt::format("{}: {}\r\n", name, value);
  }
  if (!bodiless) {
    if (!r.content_type.empty() && valid_header_line("Content-Type", r.content_type))
      out += fmt::format("Content-Type: {}\r\n", r.content_type);
    out += fmt::format("Content-Length: {}\r\n", body.size());
  }
  if (zipped) out += "Content-Encoding: gzip\r\nVary: Accept-Encoding\r\n";
  out += framing.keep_alive ? "Connection: keep-alive\r\n\r\n" : "Connection: close\r\n\r\n";
  if (!bodiless && !framing.head) out += body;
  return out;
}

std::string error_bytes(int status, const std::string& message) {
  return write_response(error_response(status, message), {.keep_alive = false});
}

}  // namespace strata::server::wire
