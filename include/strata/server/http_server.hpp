#pragma once
/// @file
/// @brief `strata serve`'s HTTP layer: cpp-httplib bound to a host and port, every request
/// handed to the Api, and a clean stop on SIGINT/SIGTERM.
#include <atomic>
#include <memory>
#include <string>

namespace strata::server {

class Api;

struct ServerOptions {
  std::string host = "127.0.0.1";  ///< loopback unless the caller says otherwise
  int port = 8080;                 ///< 0 = any free port (tests)
  int threads = 16;                ///< connections served at once (the rest wait in the backlog)
  std::size_t max_body_bytes = 1 << 20;  ///< larger request bodies are refused (413)
};

class HttpServer {
 public:
  /// @brief `api` must outlive the server.
  HttpServer(Api& api, ServerOptions options);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// @brief Binds the socket; returns the port (the chosen one for port 0). Throws Error
  /// naming the host and port when that fails.
  int bind();
  /// @brief Serves until stop() (call bind() first). Returns at once if stop() came earlier.
  void listen();
  /// @brief Stops accepting, answers queued frames 503 and lets running requests finish;
  /// listen() then returns. Thread-safe; idempotent.
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
