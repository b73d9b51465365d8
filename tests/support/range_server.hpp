#pragma once
// tests/support/range_server.py run for a test: an HTTP server with Range support on 127.0.0.1
// serving one folder (its first path component chooses normal, no-range, truncated, reset or
// flaky answers; see the script). Started by the constructor, killed by the destructor.
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "support/test_support.hpp"

namespace strata::test {

class RangeServer {
 public:
  explicit RangeServer(const std::filesystem::path& folder) {
    const std::filesystem::path script =
        test_data("NOTICE").parent_path().parent_path() / "support" / "range_server.py";
    int out[2];
    if (::pipe(out) != 0) throw std::runtime_error("pipe failed");
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], STDOUT_FILENO);
      ::close(out[0]);
      ::close(out[1]);
      ::execlp("python3", "python3", script.c_str(), folder.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(out[1]);
    std::FILE* in = ::fdopen(out[0], "r");
    int port = 0;
    const bool ready = in && std::fscanf(in, "PORT %d", &port) == 1;
    if (in) std::fclose(in);
    if (!ready) {
      stop();
      throw std::runtime_error("tests/support/range_server.py did not start");
    }
    base_ = "http://127.0.0.1:" + std::to_string(port);
  }
  ~RangeServer() { stop(); }
  RangeServer(const RangeServer&) = delete;
  RangeServer& operator=(const RangeServer&) = delete;

  /// @brief The URL of `name` served in `mode` (ok, norange, truncate, reset, flaky).
  std::string url(const std::string& mode, const std::string& name) const { return base_ + "/" + mode + "/" + name; }

 private:
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  pid_t pid_ = -1;
  std::string base_;
};

}  // namespace strata::test
