#pragma once
// HTTP/1.1 on the wire (RFC 9112) as `strata serve` speaks it, without sockets: an incremental
// reader that cuts requests out of a connection's bytes (pipelined ones one after another) and
// refuses framing that two parsers could read differently, and the writer of responses. The
// socket layer (http_server.cpp) feeds the reader what arrives and sends what the writer makes.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "strata/server/http_message.hpp"

namespace strata::server::wire {

/// @brief What one request may bring (beyond it: the status the reader fails with).
struct Limits {
  std::size_t max_head_bytes = 16 << 10;  ///< request line and headers (414 for a longer line, else 431)
  std::size_t max_headers = 100;          ///< header lines (431)
  std::size_t max_body_bytes = 1 << 20;   ///< body, declared or chunked (413)
};

/// @brief A complete request as the API takes it, with what the answer's framing depends on.
struct Request {
  HttpRequest request;      ///< method, decoded path, query parameters, body
  bool keep_alive = true;   ///< HTTP/1.1 unless "Connection: close"; HTTP/1.0 only with "keep-alive"
  bool head = false;        ///< HEAD: the answer carries no body
  bool accepts_gzip = false;
};

/// @brief Cuts requests out of the bytes of one connection, as they arrive.
///
/// Accepted: origin-form targets ("/path?query"), absolute-form ("http://host/path") and "*";
/// HTTP/1.0 and 1.1; bodies framed by Content-Length (several equal values count as one) or
/// `Transfer-Encoding: chunked`; bare LF line ends; empty lines before a request line. Refused
/// with 400: malformed request lines and header lines (a space before the colon, folded lines,
/// control characters), Content-Length values that differ or are not decimal digits,
/// Content-Length beside Transfer-Encoding, several Host headers, malformed chunks. 501 for
/// other transfer codings, 505 for other HTTP versions, 417 for other expectations; the
/// limits above as noted. After a failure the connection's framing is lost: it must close.
class RequestReader {
 public:
  enum class Status { incomplete, complete, failed };
  /// @brief idle: no byte of the next request yet; head: its request line and headers are
  /// arriving; body: the head is complete, the body is arriving.
  enum class Phase { idle, head, body };

  explicit RequestReader(Limits limits = {});

  /// @brief Appends bytes that arrived.
  void feed(std::string_view bytes);
  /// @brief Parses as far as the bytes fed go: a request is complete (take() it), more bytes
  /// are needed, or the bytes cannot be a valid request (error_status()).
  Status advance();
  Phase phase() const;
  /// @brief True once per request whose head asked "Expect: 100-continue" and whose body has
  /// not arrived: the caller then sends "100 Continue".
  bool take_continue();
  /// @brief The complete request (after advance() said so); the reader moves on to the next,
  /// whose bytes may already be buffered (pipelining).
  Request take();
  int error_status() const { return error_status_; }
  const std::string& error_message() const { return error_message_; }
  /// @brief Bytes fed and not yet taken as part of a request.
  std::size_t buffered() const { return in_.size() - start_; }

 private:
  Status fail(int status, std::string message);
  Status parse_head(std::string_view head);
  Status read_chunks();

  Limits limits_;
  std::string in_;
  std::size_t start_ = 0;    // where the current request begins in in_
  std::size_t scanned_ = 0;  // how far in_ was searched for the end of the head
  std::size_t body_at_ = 0;  // where the body begins (0: head not complete)
  std::size_t chunk_at_ = 0; // chunked: where the next chunk-size line begins
  bool chunked_ = false, expect_continue_ = false;
  std::size_t content_length_ = 0;
  std::string body_;         // the decoded body of a chunked request
  std::size_t end_ = 0;      // complete: where the request ends in in_
  Request request_;
  std::string target_;
  int error_status_ = 0;
  std::string error_message_;
  Status status_ = Status::incomplete;
};

/// @brief How to frame a response.
struct Framing {
  bool keep_alive = true;
  bool head = false;          ///< HEAD: headers (with the body's Content-Length) but no body
  bool accepts_gzip = false;  ///< compress text, JSON and JavaScript bodies of 1 KiB and more
};

/// @brief The reason phrase of `status` ("Not Found"); "Unknown" for codes it does not know.
std::string_view reason_phrase(int status);

/// @brief The bytes of `response` on the wire: status line, its headers (Content-Length,
/// Transfer-Encoding and Connection set here, not taken from it; header lines with CR or LF
/// dropped), Content-Type, Content-Length (none for 1xx, 204, 304), Connection, and the body
/// (gzip-compressed when that is allowed and makes it smaller).
std::string write_response(const HttpResponse& response, const Framing& framing);

/// @brief A short JSON error response the socket layer sends on its own (400 for bad framing,
/// 408 for a time-out, 503 when full), always closing the connection.
std::string error_bytes(int status, const std::string& message);

}  // namespace strata::server::wire
