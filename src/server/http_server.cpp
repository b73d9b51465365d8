// The only translation unit that includes httplib.h. httplib pulls in <resolv.h>, whose `_res`
// macro breaks Eigen (DESIGN.md, "Known traps"), so nothing here may include Eigen, directly or
// through a strata header: the check after the includes enforces it.
#include "strata/server/http_server.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <thread>

#include <httplib.h>

#include "strata/core/error.hpp"
#include "strata/server/api.hpp"

#if defined(EIGEN_CORE_H) || defined(EIGEN_WORLD_VERSION)
#error "http_server.cpp includes Eigen (through a strata header?): httplib and Eigen must not share a translation unit"
#endif

namespace strata::server {

struct HttpServer::Impl {
  Api& api;
  ServerOptions options;
  httplib::Server server;
  int port = -1;
  // stop() and listen() may race (a signal during start-up): each sets its flag, then reads
  // the other's, so one of them always sees the other.
  std::atomic<bool> stopping{false}, listening{false}, httplib_stopped{false};

  Impl(Api& a, ServerOptions o) : api(a), options(std::move(o)) {}
  void handle(const httplib::Request& request, httplib::Response& response);
};

void HttpServer::Impl::handle(const httplib::Request& request, httplib::Response& response) {
  HttpRequest r;
  r.method = request.method;
  r.path = request.path;  // httplib has percent-decoded it
  // Parameters come from the URL's query only: httplib also parses a form-encoded body into
  // `request.params`, so a JSON body posted with a form content type (curl -d's default)
  // would turn into a parameter named after the JSON.
  const std::size_t query = request.target.find('?');
  if (query != std::string::npos) {
    httplib::Params params;
    httplib::detail::parse_query_text(request.target.substr(query + 1), params);  // percent-decodes
    for (const auto& [key, value] : params) r.params.emplace(key, value);
  }
  r.body = request.body;
  HttpResponse out = api.handle(r);
  response.status = out.status;
  for (const auto& [key, value] : out.headers) response.set_header(key, value);
  if (out.status != 204) response.set_content(std::move(out.body), out.content_type);
}

HttpServer::HttpServer(Api& api, ServerOptions options) : impl_(std::make_unique<Impl>(api, std::move(options))) {
  if (impl_->options.threads < 1) throw ParameterError("ServerOptions::threads", "must be at least 1");
  httplib::Server& s = impl_->server;
  auto handler = [this](const httplib::Request& request, httplib::Response& response) { impl_->handle(request, response); };
  // Every path and method goes to the Api, which answers 404/405 itself.
  s.Get(".*", handler);
  s.Post(".*", handler);
  s.Put(".*", handler);
  s.Delete(".*", handler);
  s.Patch(".*", handler);
  s.Options(".*", handler);
  s.set_payload_max_length(impl_->options.max_body_bytes);
  s.set_keep_alive_timeout(2);
  s.set_read_timeout(10);
  s.set_write_timeout(10);
  const std::size_t threads = std::size_t(impl_->options.threads);
  s.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  s.set_exception_handler([](const httplib::Request&, httplib::Response& response, std::exception_ptr) {
    response.status = 500;
    response.set_content(R"({"error":"internal error"})", "application/json");
  });
}

HttpServer::~HttpServer() { stop(); }

int HttpServer::bind() {
  Impl& i = *impl_;
  i.port = i.options.port == 0 ? i.server.bind_to_any_port(i.options.host)
                               : (i.server.bind_to_port(i.options.host, i.options.port) ? i.options.port : -1);
  if (i.port < 0)
    throw Error("cannot listen on " + i.options.host + ":" + std::to_string(i.options.port) +
                " (address in use, or not an address of this machine)");
  return i.port;
}

void HttpServer::listen() {
  Impl& i = *impl_;
  i.listening = true;
  if (!i.stopping) i.server.listen_after_bind();
  i.listening = false;
}

void HttpServer::stop() {
  Impl& i = *impl_;
  i.stopping = true;
  i.api.stop_rendering();
  // A listen() that has begun either returns at once or is about to run: wait until it runs,
  // then stop httplib once (its stop() is not meant to be called twice).
  while (i.listening && !i.server.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  if (i.server.is_running() && !i.httplib_stopped.exchange(true)) i.server.stop();
}

bool HttpServer::running() const { return impl_->server.is_running(); }

std::string HttpServer::url() const {
  const std::string& host = impl_->options.host;
  const bool v6 = host.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + host + "]" : host) + ":" + std::to_string(impl_->port) + "/";
}

namespace {

// Write end of the self-pipe; the handler only writes one byte (async-signal-safe).
std::atomic<int> g_signal_pipe{-1};

extern "C" void on_stop_signal(int) {
  const char byte = 1;
  const int fd = g_signal_pipe.load();
  if (fd < 0) return;
  const ssize_t written = ::write(fd, &byte, 1);
  (void)written;  // a full pipe already holds a stop request
}

}  // namespace

void serve_until_signal(HttpServer& server) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC | O_NONBLOCK) != 0) throw Error("serve: cannot create the signal pipe");
  g_signal_pipe = fds[1];
  struct sigaction action {}, old_int{}, old_term{};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGINT, &action, &old_int);
  sigaction(SIGTERM, &action, &old_term);
  std::atomic<bool> done{false};
  std::thread watcher([&] {
    pollfd p{fds[0], POLLIN, 0};
    while (!done) {
      if (::poll(&p, 1, 100) > 0 && (p.revents & POLLIN)) {
        server.stop();
        return;
      }
    }
  });
  server.listen();
  done = true;
  watcher.join();
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  g_signal_pipe = -1;
  ::close(fds[0]);
  ::close(fds[1]);
}

}  // namespace strata::server
