// `strata serve`'s HTTP/1.1 server: one event-loop thread owns every connection (non-blocking
// sockets under poll()), reads request heads and bodies under deadlines and byte limits, and
// hands complete requests to a pool of workers that run the Api; the loop writes the answers.
// A slow client therefore costs a socket and a buffer, never a thread: the workers only ever
// see complete requests. Pipelined requests are taken one at a time, in order: the next is cut
// from the connection's bytes when the answer to the previous one has been written.
#include "strata/server/http_server.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <tuple>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "server/http_wire.hpp"
#include "strata/core/error.hpp"
#include "strata/server/api.hpp"

namespace strata::server {

namespace {

using Clock = std::chrono::steady_clock;
using Phase = wire::RequestReader::Phase;

constexpr std::size_t kReadChunk = 16 << 10;      // one recv()
constexpr int kReadsPerWake = 4;                  // at most 64 KiB from one connection per loop turn
constexpr auto kLinger = std::chrono::seconds(2);  // reading what a closing client still sends
constexpr std::size_t kLingerBytes = 256 << 10;
constexpr auto kDrainWrites = std::chrono::seconds(5);  // answers still sent after stop()
constexpr int kAcceptsPerWake = 256;
constexpr int kReservedFds = 64;                  // dataset files, pipes, the listener

Clock::duration after_seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// "address already in use": strerror's text, lower case as it continues a message.
std::string errno_text(int error) {
  std::string text = std::strerror(error);
  if (!text.empty()) text[0] = char(std::tolower(static_cast<unsigned char>(text[0])));
  if (error == EADDRINUSE) text += " (another program listens there)";
  if (error == EADDRNOTAVAIL) text += " (not an address of this machine)";
  return text;
}

std::string host_port(const std::string& host, int port) {
  const bool v6 = host.find(':') != std::string::npos;
  return (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

struct Connection {
  enum class State { reading, processing, writing, lingering };
  Connection(int f, std::uint64_t i, const wire::Limits& limits) : fd(f), id(i), reader(limits) {}

  int fd;
  std::uint64_t id;
  State state = State::reading;
  wire::RequestReader reader;
  std::optional<Phase> phase;  // the reader's phase when the deadline was set (none: set it anew)
  Clock::time_point since;     // when that phase (or state) began
  Clock::time_point deadline = Clock::time_point::max();
  std::string out;             // bytes to send, from `sent` on
  std::size_t sent = 0;
  bool close_after = false;    // close once `out` is sent
  bool peer_closed = false;    // the client sent its last byte
  std::size_t answered = 0;    // answers sent on this connection
  std::size_t lingered = 0;
};

struct Job {
  std::uint64_t connection;
  wire::Request request;
};

struct Answer {
  std::uint64_t connection;
  std::string bytes;
  bool close = false;  // the answer says "Connection: close" whatever the request asked
};

}  // namespace

struct HttpServer::Impl {
  Api& api;
  ServerOptions options;
  wire::Limits limits;
  int listen_fd = -1, wake_fd = -1, port = -1;
  std::atomic<bool> stopping{false}, accepting{false};

  std::mutex jobs_mutex;
  std::condition_variable jobs_ready;
  std::deque<Job> jobs;
  bool workers_stop = false;
  std::mutex answers_mutex;
  std::vector<Answer> answers;

  // The loop's own (its thread only).
  std::unordered_map<std::uint64_t, std::unique_ptr<Connection>> connections;
  std::uint64_t next_id = 1;
  std::size_t max_connections = 0;
  Clock::time_point accept_paused_until{};
  bool draining = false;

  Impl(Api& a, ServerOptions o) : api(a), options(std::move(o)) {
    limits.max_head_bytes = options.max_head_bytes;
    limits.max_body_bytes = options.max_body_bytes;
  }
  ~Impl() {
    if (listen_fd >= 0) ::close(listen_fd);
    if (wake_fd >= 0) ::close(wake_fd);
  }

  void wake() const {
    const std::uint64_t one = 1;
    const ssize_t written = ::write(wake_fd, &one, sizeof one);
    (void)written;  // a full counter already wakes the loop
  }
  void work();
  void loop();
  void begin_drain(Clock::time_point now);
  void accept_all(Clock::time_point now);
  bool evict_one();
  void on_event(Connection& c, short revents, Clock::time_point now);
  void read_from(Connection& c, Clock::time_point now);
  void advance(Connection& c, Clock::time_point now);
  void send_bytes(Connection& c, std::string bytes, bool close_after, Clock::time_point now);
  void flush(Connection& c, Clock::time_point now);
  void finish_answer(Connection& c, Clock::time_point now);
  void check_deadline(Connection& c, Clock::time_point now);
  void close(Connection& c);
};

void HttpServer::Impl::work() {
  while (true) {
    Job job;
    {
      std::unique_lock lock(jobs_mutex);
      jobs_ready.wait(lock, [&] { return workers_stop || !jobs.empty(); });
      if (jobs.empty()) return;
      job = std::move(jobs.front());
      jobs.pop_front();
    }
    std::string bytes;
    bool close = false;
    try {
      const HttpResponse response = api.handle(job.request.request);
      bytes = wire::write_response(response, {.keep_alive = job.request.keep_alive,
                                              .head = job.request.head,
                                              .accepts_gzip = job.request.accepts_gzip});
    } catch (...) {  // handle() does not throw; an allocation failure while writing might
      bytes = wire::error_bytes(500, "internal error");
      close = true;
    }
    {
      std::lock_guard lock(answers_mutex);
      answers.push_back({job.connection, std::move(bytes), close});
    }
    wake();
  }
}

void HttpServer::Impl::close(Connection& c) {
  if (c.fd >= 0) ::close(c.fd);
  c.fd = -1;
}

// Nothing is read while a request runs or its answer is sent, so a client cannot pile up
// pipelined bytes: a connection holds at most one request, its answer and 64 KiB read ahead.
void HttpServer::Impl::read_from(Connection& c, Clock::time_point now) {
  char buffer[kReadChunk];
  if (c.state == Connection::State::lingering) {
    const ssize_t n = ::recv(c.fd, buffer, sizeof buffer, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) return close(c);
    if (n > 0 && (c.lingered += std::size_t(n)) > kLingerBytes) close(c);
    return;
  }
  if (c.state != Connection::State::reading) return;
  for (int i = 0; i < kReadsPerWake; ++i) {
    const ssize_t n = ::recv(c.fd, buffer, sizeof buffer, 0);
    if (n > 0) {
      c.reader.feed(std::string_view(buffer, std::size_t(n)));
      if (std::size_t(n) < sizeof buffer) break;
    } else if (n == 0) {
      c.peer_closed = true;
      break;
    } else if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
      break;
    } else {
      return close(c);
    }
  }
  advance(c, now);
}

// Cuts the next request out of the connection's bytes: runs it, refuses it, or waits for more
// under the deadline of the phase it is in.
void HttpServer::Impl::advance(Connection& c, Clock::time_point now) {
  const auto status = c.reader.advance();
  if (c.reader.take_continue()) send_bytes(c, "HTTP/1.1 100 Continue\r\n\r\n", false, now);
  if (c.fd < 0) return;
  if (status == wire::RequestReader::Status::failed)
    return send_bytes(c, wire::error_bytes(c.reader.error_status(), c.reader.error_message()), true, now);
  if (status == wire::RequestReader::Status::complete) {
    Job job{c.id, c.reader.take()};
    if (draining) job.request.keep_alive = false;
    c.close_after = !job.request.keep_alive;
    c.state = Connection::State::processing;
    c.phase.reset();
    c.deadline = Clock::time_point::max();
    {
      std::lock_guard lock(jobs_mutex);
      jobs.push_back(std::move(job));
    }
    jobs_ready.notify_one();
    return;
  }
  if (c.peer_closed) return close(c);  // a request cut short never completes
  const Phase phase = c.reader.phase();
  if (c.phase == phase) return;
  c.phase = phase;
  c.since = now;
  c.deadline = now + after_seconds(phase == Phase::idle   ? options.idle_timeout_s
                                   : phase == Phase::head ? options.head_timeout_s
                                                          : options.body_timeout_s);
}

void HttpServer::Impl::send_bytes(Connection& c, std::string bytes, bool close_after, Clock::time_point now) {
  if (c.sent > 0) {
    c.out.erase(0, c.sent);
    c.sent = 0;
  }
  c.out += bytes;
  if (close_after) c.close_after = true;
  if (c.state != Connection::State::reading || close_after) {
    c.state = Connection::State::writing;
    c.since = now;
    c.deadline = now + after_seconds(options.write_timeout_s);
    if (draining) c.deadline = std::min(c.deadline, now + kDrainWrites);
  }
  flush(c, now);
}

void HttpServer::Impl::flush(Connection& c, Clock::time_point now) {
  while (c.sent < c.out.size()) {
    const ssize_t n = ::send(c.fd, c.out.data() + c.sent, c.out.size() - c.sent, MSG_NOSIGNAL);
    if (n > 0) c.sent += std::size_t(n);
    else if (n < 0 && errno == EINTR) continue;
    else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    else return close(c);
  }
  c.out.clear();
  c.sent = 0;
  if (c.state == Connection::State::writing) {
    ++c.answered;
    finish_answer(c, now);
  }
}

// The answer is out: close (reading what the client still sends for a moment, so that its
// unread bytes do not turn the close into a reset that could discard the answer), or go on to
// the next request, which may be buffered already.
void HttpServer::Impl::finish_answer(Connection& c, Clock::time_point now) {
  if (c.close_after || draining) {
    ::shutdown(c.fd, SHUT_WR);
    c.state = Connection::State::lingering;
    c.since = now;
    c.deadline = now + kLinger;
    return;
  }
  c.state = Connection::State::reading;
  c.phase.reset();
  advance(c, now);
}

void HttpServer::Impl::check_deadline(Connection& c, Clock::time_point now) {
  if (c.fd < 0 || now < c.deadline) return;
  if (c.state == Connection::State::reading && c.phase && *c.phase != Phase::idle) {
    const bool head = *c.phase == Phase::head;
    const double limit = head ? options.head_timeout_s : options.body_timeout_s;
    return send_bytes(c, wire::error_bytes(408, fmt::format("the request {} did not arrive within {} s", head ? "head" : "body", limit)),
                      true, now);
  }
  close(c);  // idle keep-alive, an answer not taken, a lingering close
}

// At the cap a new connection takes the place of one that is cheapest to drop: a closing one,
// else one kept alive after its answers (the longest idle), else the one whose request has been
// arriving the longest (a new connection that has sent nothing yet counts from its accept).
// Connections whose request runs or whose answer is being sent are kept.
bool HttpServer::Impl::evict_one() {
  const auto cost = [](const Connection& c) {
    const int rank = c.state == Connection::State::lingering ? 0
                     : c.state != Connection::State::reading ? 3
                     : c.phase == Phase::idle && c.answered > 0 ? 1
                                                                : 2;
    return std::tuple(rank, c.since, c.id);
  };
  Connection* victim = nullptr;
  for (auto& [id, c] : connections)
    if (c->fd >= 0 && std::get<0>(cost(*c)) < 3 && (!victim || cost(*c) < cost(*victim))) victim = c.get();
  if (!victim) return false;
  close(*victim);
  return true;
}

void HttpServer::Impl::accept_all(Clock::time_point now) {
  static const std::string busy = wire::error_bytes(503, "too many connections");
  for (int i = 0; i < kAcceptsPerWake; ++i) {
    const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      // Out of descriptors or memory: leave the rest in the backlog for a moment.
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM)
        accept_paused_until = now + std::chrono::milliseconds(100);
      return;
    }
    std::size_t open = 0;
    for (const auto& [id, c] : connections) open += c->fd >= 0 ? 1 : 0;
    if (open >= max_connections && !evict_one()) {
      const ssize_t sent = ::send(fd, busy.data(), busy.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      (void)sent;
      ::close(fd);
      continue;
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    auto c = std::make_unique<Connection>(fd, next_id++, limits);
    advance(*c, now);  // sets the idle deadline
    connections.emplace(c->id, std::move(c));
  }
}

void HttpServer::Impl::on_event(Connection& c, short revents, Clock::time_point now) {
  if (c.fd < 0) return;
  if ((revents & (POLLOUT | POLLERR | POLLHUP)) && c.sent < c.out.size()) flush(c, now);
  if (c.fd >= 0 && (revents & (POLLIN | POLLERR | POLLHUP)) &&
      (c.state == Connection::State::reading || c.state == Connection::State::lingering))
    read_from(c, now);
}

// stop(): no new connections; connections between requests close at once; running requests
// finish and their answers are sent (for a few seconds at most), with "Connection: close".
void HttpServer::Impl::begin_drain(Clock::time_point now) {
  draining = true;
  accepting = false;
  if (listen_fd >= 0) ::close(listen_fd);
  listen_fd = -1;
  for (auto& [id, c] : connections) {
    if (c->state == Connection::State::reading || c->state == Connection::State::lingering) close(*c);
    if (c->state == Connection::State::writing) c->deadline = std::min(c->deadline, now + kDrainWrites);
  }
}

void HttpServer::Impl::loop() {
  std::vector<pollfd> fds;
  std::vector<std::uint64_t> ids;
  while (true) {
    Clock::time_point now = Clock::now();
    if (stopping && !draining) begin_drain(now);
    std::erase_if(connections, [](const auto& entry) { return entry.second->fd < 0; });
    if (draining && connections.empty()) return;

    fds.assign({pollfd{wake_fd, POLLIN, 0}});
    ids.clear();
    const bool listen_now = listen_fd >= 0 && now >= accept_paused_until;
    if (listen_now) fds.push_back({listen_fd, POLLIN, 0});
    const std::size_t first = fds.size();
    Clock::time_point next = listen_fd >= 0 && !listen_now ? accept_paused_until : now + std::chrono::seconds(1);
    for (const auto& [id, c] : connections) {
      short events = 0;
      if (c->state == Connection::State::reading || c->state == Connection::State::lingering) events |= POLLIN;
      if (c->sent < c->out.size()) events |= POLLOUT;
      if (events == 0) continue;  // a request running: its socket waits
      fds.push_back({c->fd, events, 0});
      ids.push_back(id);
      next = std::min(next, c->deadline);
    }
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(next - now).count();
    const int ready = ::poll(fds.data(), fds.size(), int(std::clamp<std::int64_t>(wait, 0, 1000)));
    if (ready < 0 && errno != EINTR) throw Error(std::string("serve: poll failed: ") + std::strerror(errno));
    now = Clock::now();

    if (fds[0].revents & POLLIN) {
      std::uint64_t count;
      const ssize_t got = ::read(wake_fd, &count, sizeof count);
      (void)got;
    }
    std::vector<Answer> done;
    {
      std::lock_guard lock(answers_mutex);
      done.swap(answers);
    }
    for (Answer& a : done) {
      const auto it = connections.find(a.connection);
      if (it != connections.end() && it->second->fd >= 0 && it->second->state == Connection::State::processing)
        send_bytes(*it->second, std::move(a.bytes), it->second->close_after || a.close, now);
    }
    if (listen_now && (fds[1].revents & POLLIN)) accept_all(now);
    for (std::size_t i = first; i < fds.size(); ++i)
      if (fds[i].revents != 0)
        if (const auto it = connections.find(ids[i - first]); it != connections.end()) on_event(*it->second, fds[i].revents, now);
    for (auto& [id, c] : connections) check_deadline(*c, now);
  }
}

HttpServer::HttpServer(Api& api, ServerOptions options) : impl_(std::make_unique<Impl>(api, std::move(options))) {
  const ServerOptions& o = impl_->options;
  if (o.threads < 1) throw ParameterError("ServerOptions::threads", "must be at least 1");
  if (o.max_connections < 1) throw ParameterError("ServerOptions::max_connections", "must be at least 1");
  if (o.max_head_bytes < 1024) throw ParameterError("ServerOptions::max_head_bytes", "must be at least 1024");
  const std::pair<double, const char*> timeouts[] = {{o.head_timeout_s, "head_timeout_s"}, {o.body_timeout_s, "body_timeout_s"},
                                                     {o.idle_timeout_s, "idle_timeout_s"}, {o.write_timeout_s, "write_timeout_s"}};
  for (const auto& [value, name] : timeouts)
    if (!(value > 0 && value <= 86400))
      throw ParameterError(std::string("ServerOptions::") + name, "must be a number of seconds in (0, 86400]");
  impl_->wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (impl_->wake_fd < 0) throw Error(std::string("serve: cannot create an eventfd: ") + std::strerror(errno));
}

HttpServer::~HttpServer() { stop(); }

// SO_REUSEADDR only: a restarted server binds while connections of the previous one are in
// TIME_WAIT, but a second server on a port in use fails (SO_REUSEPORT would let it in beside
// the first, and the kernel would share the connections between the two).
int HttpServer::bind() {
  Impl& i = *impl_;
  const std::string& host = i.options.host;
  const std::string where = host_port(host, i.options.port);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const int resolved = ::getaddrinfo(host.empty() ? nullptr : host.c_str(), std::to_string(i.options.port).c_str(), &hints, &found);
  if (resolved != 0) throw Error("cannot listen on " + where + ": " + ::gai_strerror(resolved));
  int error = 0;
  for (const addrinfo* a = found; a && i.listen_fd < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) {
      error = errno;
      continue;
    }
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) != 0 || ::listen(fd, SOMAXCONN) != 0) {
      error = errno;
      ::close(fd);
      continue;
    }
    i.listen_fd = fd;
  }
  ::freeaddrinfo(found);
  if (i.listen_fd < 0) throw Error("cannot listen on " + where + ": " + errno_text(error));
  sockaddr_storage bound{};
  socklen_t length = sizeof bound;
  ::getsockname(i.listen_fd, reinterpret_cast<sockaddr*>(&bound), &length);
  i.port = bound.ss_family == AF_INET6 ? ntohs(reinterpret_cast<const sockaddr_in6&>(bound).sin6_port)
                                       : ntohs(reinterpret_cast<const sockaddr_in&>(bound).sin_port);
  return i.port;
}

void HttpServer::listen() {
  Impl& i = *impl_;
  if (i.listen_fd < 0) throw Error("HttpServer::listen: call bind() first");
  if (i.stopping) return;
  // Connections at most: the option, within the descriptors the process may open.
  rlimit files{};
  std::size_t cap = std::size_t(i.options.max_connections);
  if (::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur != RLIM_INFINITY)
    cap = std::min<std::size_t>(cap, std::max<std::int64_t>(8, std::int64_t(files.rlim_cur) - kReservedFds));
  i.max_connections = cap;
  std::vector<std::thread> workers;
  for (int t = 0; t < i.options.threads; ++t) workers.emplace_back([&i] { i.work(); });
  const auto finish = [&] {  // the workers finish their jobs and stop; the connections close
    i.accepting = false;
    {
      std::lock_guard lock(i.jobs_mutex);
      i.workers_stop = true;
    }
    i.jobs_ready.notify_all();
    for (std::thread& t : workers) t.join();
    for (auto& [id, c] : i.connections) i.close(*c);
    i.connections.clear();
  };
  i.accepting = true;
  try {
    i.loop();
  } catch (...) {
    finish();
    throw;
  }
  finish();
}

void HttpServer::stop() {
  Impl& i = *impl_;
  if (i.stopping.exchange(true)) return;
  i.api.stop_rendering();
  i.wake();
}

bool HttpServer::running() const { return impl_->accepting; }

std::string HttpServer::url() const { return "http://" + host_port(impl_->options.host, impl_->port) + "/"; }

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
