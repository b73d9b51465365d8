#pragma once
// A raw HTTP/1.1 client over one loopback TCP connection, for tests that need what a library
// client hides: bytes sent exactly as written (several requests at once, malformed heads,
// headers trickled line by line) and responses read one after another off the same connection.
// Every wait has a deadline, so a server that does not answer fails a test instead of hanging it.
// Header-only and free of Eigen and httplib.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace strata::test {

/// @brief One response as read off the wire.
struct RawResponse {
  int status = 0;
  std::vector<std::pair<std::string, std::string>> headers;  // names lower-cased
  std::string body;
  std::string header(const std::string& lower_name) const {
    for (const auto& [name, value] : headers)
      if (name == lower_name) return value;
    return {};
  }
};

class RawHttp {
 public:
  using Clock = std::chrono::steady_clock;

  /// @brief Connects to 127.0.0.1:port within `seconds` (connected() says whether it did).
  explicit RawHttp(int port, double seconds = 5) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd_ < 0) return;
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(std::uint16_t(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) {
      connected_ = true;
      return;
    }
    if (errno != EINPROGRESS) return;
    pollfd p{fd_, POLLOUT, 0};
    int error = 0;
    socklen_t length = sizeof error;
    connected_ = ::poll(&p, 1, int(seconds * 1000)) == 1 &&
                 ::getsockopt(fd_, SOL_SOCKET, SO_ERROR, &error, &length) == 0 && error == 0;
  }
  ~RawHttp() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawHttp(RawHttp&& other) noexcept
      : fd_(std::exchange(other.fd_, -1)), connected_(other.connected_), in_(std::move(other.in_)) {}
  RawHttp& operator=(RawHttp&&) = delete;

  bool connected() const { return connected_; }

  /// @brief Sends all of `bytes` within `seconds`; false when the connection refused them.
  bool send(std::string_view bytes, double seconds = 5) {
    const auto deadline = after(seconds);
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n > 0) {
        bytes.remove_prefix(std::size_t(n));
      } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        if (!wait(POLLOUT, deadline)) return false;
      } else if (n < 0 && errno != EINTR) {
        return false;
      }
    }
    return true;
  }

  /// @brief The next response, read within `seconds` (nullopt on a time-out, a close before a
  /// whole response, or bytes that are not one). `head_request`: the answer to a HEAD, whose
  /// Content-Length describes a body that is not sent.
  std::optional<RawResponse> read_response(double seconds = 10, bool head_request = false) {
    const auto deadline = after(seconds);
    std::size_t end;
    while ((end = in_.find("\r\n\r\n")) == std::string::npos)
      if (!fill(deadline)) return std::nullopt;
    RawResponse r;
    const std::string head = in_.substr(0, end + 2);
    const std::size_t first_line = head.find("\r\n");
    if (!head.starts_with("HTTP/1.") || head.size() < 12) return std::nullopt;
    r.status = std::atoi(head.c_str() + 9);
    for (std::size_t at = first_line + 2; at < head.size();) {
      const std::size_t line_end = head.find("\r\n", at);
      const std::string line = head.substr(at, line_end - at);
      at = line_end + 2;
      const std::size_t colon = line.find(':');
      if (colon == std::string::npos) return std::nullopt;
      std::string name = line.substr(0, colon);
      for (char& c : name) c = char(std::tolower(static_cast<unsigned char>(c)));
      std::string value = line.substr(colon + 1);
      while (!value.empty() && value.front() == ' ') value.erase(0, 1);
      r.headers.emplace_back(std::move(name), std::move(value));
    }
    in_.erase(0, end + 4);
    const std::string length = r.header("content-length");
    const std::size_t size = head_request || length.empty() ? 0 : std::size_t(std::stoull(length));
    while (in_.size() < size)
      if (!fill(deadline)) return std::nullopt;
    r.body = in_.substr(0, size);
    in_.erase(0, size);
    return r;
  }

  /// @brief True when the server closes the connection within `seconds` (bytes it sends first
  /// are kept for read_response).
  bool closed_by_peer(double seconds = 10) {
    const auto deadline = after(seconds);
    while (true) {
      const ssize_t got = receive();
      if (got == 0) return true;
      if (got < 0 && !wait(POLLIN, deadline)) return false;
    }
  }

  /// @brief True while the server has neither sent anything nor closed the connection.
  bool silent_and_open() {
    char byte;
    const ssize_t n = ::recv(fd_, &byte, 1, MSG_PEEK | MSG_DONTWAIT);
    return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && in_.empty();
  }

 private:
  static Clock::time_point after(double seconds) {
    return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  }
  bool wait(short events, Clock::time_point deadline) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return false;
    pollfd p{fd_, events, 0};
    return ::poll(&p, 1, int(left)) == 1;
  }
  // Appends what has arrived: the byte count, 0 at the peer's close, -1 when nothing is there yet
  // (or on an error, reported as a close).
  ssize_t receive() {
    char buffer[16384];
    const ssize_t n = ::recv(fd_, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n > 0) in_.append(buffer, std::size_t(n));
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return 0;
    return n;
  }
  bool fill(Clock::time_point deadline) {
    while (true) {
      const ssize_t got = receive();
      if (got > 0) return true;
      if (got == 0 || !wait(POLLIN, deadline)) return false;
    }
  }

  int fd_ = -1;
  bool connected_ = false;
  std::string in_;
};

}  // namespace strata::test
