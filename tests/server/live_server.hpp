#pragma once
// The real HTTP server on a free loopback port, listening on its own thread until the object
// dies. Free of Eigen and httplib (the tests that include it may include httplib.h).
#include <thread>
#include <utility>

#include <gtest/gtest.h>

#include "server/server_test_util.hpp"
#include "strata/server/http_server.hpp"

namespace strata::server::testing {

class LiveServer {
 public:
  explicit LiveServer(Api& api, ServerOptions options = {}) : server_(api, with_any_port(std::move(options))) {
    port_ = server_.bind();
    thread_ = std::thread([this] { server_.listen(); });
    if (!eventually([this] { return server_.running(); })) ADD_FAILURE() << "the server did not start listening";
  }
  ~LiveServer() {
    server_.stop();
    thread_.join();
  }
  LiveServer(const LiveServer&) = delete;
  LiveServer& operator=(const LiveServer&) = delete;
  int port() const { return port_; }

 private:
  static ServerOptions with_any_port(ServerOptions o) {
    o.port = 0;
    return o;
  }
  HttpServer server_;
  int port_ = 0;
  std::thread thread_;
};

}  // namespace strata::server::testing
