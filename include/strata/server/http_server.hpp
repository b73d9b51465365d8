#pragma once
/// @file
/// @brief `strata serve`'s HTTP layer: an HTTP/1.1 server bound to a host and port, every
/// request handed to the Api, and a clean stop on SIGINT/SIGTERM.
///
/// One thread owns the connections (non-blocking sockets under poll()) and reads each request
/// whole, within the limits below, before a worker runs it; slow clients therefore hold no
/// worker. Keep-alive and pipelining as HTTP/1.1 has them: requests on one connection are
/// answered one after another, in order. Framing that could be read two ways (Content-Length
/// values that differ, Content-Length beside Transfer-Encoding) is refused with 400.
#include <atomic>
#include <cstddef>
#include <memory>
#include <string>

namespace strata::server {

class Api;

/// @brief Where to listen and what a client may cost (docs/viewer.md, "Limits").
struct ServerOptions {
  std::string host = "127.0.0.1";  ///< loopback unless the caller says otherwise
  int port = 8080;                 ///< 0 = any free port (tests)
  int threads = 16;                ///< requests run at once (workers); complete requests beyond wait for one
  /// Open connections at most (also bounded by the process's descriptor limit). A connection
  /// beyond it takes the place of the one that is cheapest to drop (closing, idle the longest,
  /// or whose request has been arriving the longest); when every one is busy it gets 503.
  int max_connections = 512;
  std::size_t max_head_bytes = 16 << 10;  ///< request line and headers (414 / 431 beyond)
  std::size_t max_body_bytes = 1 << 20;   ///< larger request bodies are refused (413)
  double head_timeout_s = 10;   ///< a request head must arrive whole within this of its first byte (408)
  double body_timeout_s = 30;   ///< the body within this of the head's end (408)
  double idle_timeout_s = 5;    ///< a kept-alive connection without a request is closed after this
  double write_timeout_s = 30;  ///< an answer must be taken by the client within this, or the connection closes
};

class HttpServer {
 public:
  /// @brief `api` must outlive the server.
  HttpServer(Api& api, ServerOptions options);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// @brief Binds the socket; returns the port (the chosen one for port 0). Throws Error
  /// naming the host and port and why when that fails ("address already in use" when another
  /// program listens there: the socket has SO_REUSEADDR but not SO_REUSEPORT, so a second
  /// server never shares a port with the first).
  int bind();
  /// @brief Serves until stop() (call bind() first). Returns at once if stop() came earlier.
  void listen();
  /// @brief Stops accepting and closes connections between requests, answers queued frames
  /// 503, lets running requests finish and sends their answers (5 s at most); listen() then
  /// returns. Thread-safe; idempotent.
  void stop();
  /// @brief True while listen() accepts connections.
  bool running() const;
  /// @brief "http://host:port/".
  std::string url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief Runs server.listen() until SIGINT or SIGTERM arrives (or stop() is called), then
/// stops it cleanly and restores the previous signal handlers.
void serve_until_signal(HttpServer& server);

}  // namespace strata::server
