// `strata serve` as a program: a second one on a busy port fails naming the address, and a
// folder with files that do not open is served without them (a warning each), or is an error
// when nothing is left.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cli_test_util.hpp"
#include "support/raw_http.hpp"
#include "support/test_support.hpp"

namespace strata::test {
namespace {

namespace fs = std::filesystem;

// `strata serve ARGS --port 0` running in the background: its port once it says "Serving on",
// its standard error in a file, stopped by SIGTERM when the object dies.
class ServeProcess {
 public:
  ServeProcess(const std::vector<std::string>& args, const fs::path& stderr_file) {
    std::vector<std::string> all{STRATA_BINARY, "--progress", "none", "serve"};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    int out[2];
    if (::pipe(out) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], STDOUT_FILENO);
      const int err = ::open(stderr_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(err, STDERR_FILENO);
      ::close(out[0]);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(out[1]);
    out_ = out[0];
  }
  ~ServeProcess() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGTERM);
      wait_exit(10);
      if (!exited_) {
        ::kill(pid_, SIGKILL);
        wait_exit(10);
      }
    }
    if (out_ >= 0) ::close(out_);
  }

  // The port of the "Serving on http://127.0.0.1:PORT/" line, read within `seconds`; 0 when the
  // program exits or says nothing of the kind in that time.
  int port(double seconds = 60) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    const std::regex serving(R"(Serving on http://[^:]+:(\d+)/)");
    while (std::chrono::steady_clock::now() < deadline) {
      std::smatch m;
      if (std::regex_search(stdout_, m, serving)) return std::stoi(m[1]);
      pollfd p{out_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      char buffer[4096];
      const ssize_t n = ::read(out_, buffer, sizeof buffer);
      if (n <= 0) return 0;
      stdout_.append(buffer, std::size_t(n));
    }
    return 0;
  }
  // The exit code once the program has exited within `seconds`; -1 when it is still running.
  int wait_exit(double seconds) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!exited_) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      } else if (std::chrono::steady_clock::now() > deadline) {
        return -1;
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
    return code_;
  }
  const std::string& output() const { return stdout_; }

 private:
  pid_t pid_ = -1;
  int out_ = -1;
  bool exited_ = false;
  int code_ = -1;
  std::string stdout_;
};

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json datasets_of(int port) {
  RawHttp c(port);
  if (!c.send("GET /api/datasets HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")) return nullptr;
  const auto r = c.read_response(30);
  return r && r->status == 200 ? nlohmann::json::parse(r->body) : nullptr;
}

// A tiny volume `name` in `dir` (.nrrd, or .strata compressed from one).
void make_volume(const TempDir& dir, const std::string& name) {
  std::string out;
  const fs::path nrrd = dir / (fs::path(name).stem().string() + ".src.nrrd");
  ASSERT_EQ(run_command(strata_cmd("generate sphere --size 12,10,8 -o " + shell_quoted(nrrd)), &out), 0) << out;
  if (name.ends_with(".strata")) {
    ASSERT_EQ(run_command(strata_cmd("compress " + shell_quoted(nrrd) + " -o " + shell_quoted(dir / name)), &out), 0) << out;
    fs::remove(nrrd);
  } else {
    fs::rename(nrrd, dir / name);
  }
}

// A second `strata serve` on the port of a running one fails at once, naming the address and
// the reason, instead of starting beside it and taking a share of its requests.
TEST(CliServer, ASecondServerOnABusyPortFailsNamingTheAddress) {
  TempDir dir;
  make_volume(dir, "ball.nrrd");
  ServeProcess first({(dir / "ball.nrrd").string(), "--port", "0"}, dir / "first.err");
  const int port = first.port();
  ASSERT_GT(port, 0) << first.output() << read_text(dir / "first.err");
  ServeProcess second({(dir / "ball.nrrd").string(), "--port", std::to_string(port)}, dir / "second.err");
  const int code = second.wait_exit(30);
  const std::string message = read_text(dir / "second.err");
  EXPECT_EQ(code, 1) << "a second server on a busy port exits with an error, not serve beside the first\n" << message;
  EXPECT_NE(message.find("error: cannot listen on 127.0.0.1:" + std::to_string(port)), std::string::npos) << message;
  EXPECT_NE(message.find("address already in use"), std::string::npos) << message;
  EXPECT_EQ(datasets_of(port).size(), 1u) << "the first server still answers";
}

// One file of a folder that does not open (damaged, unreadable) is skipped with a warning naming
// it and why; the rest is served.
TEST(CliServer, AFolderIsServedWithoutTheFilesThatDoNotOpen) {
  TempDir dir;
  make_volume(dir, "good.nrrd");
  make_volume(dir, "broken.strata");
  flip_byte(dir / "broken.strata", 20);  // the header's checksum no longer matches
  std::ofstream(dir / "garbled.nrrd") << "NRRD0004\ntype: quaternion\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n12345678";
  make_volume(dir, "locked.nrrd");
  fs::permissions(dir / "locked.nrrd", fs::perms::none);
  const bool locked_unreadable = !std::ifstream(dir / "locked.nrrd").is_open();  // root reads it anyway

  ServeProcess serve({dir.path().string(), "--port", "0"}, dir / "serve.err");
  const int port = serve.port();
  const std::string warnings = read_text(dir / "serve.err");
  ASSERT_GT(port, 0) << "serves the folder despite the files that do not open\n" << serve.output() << warnings;
  for (const std::string name : {"broken.strata", "garbled.nrrd"}) {
    const std::size_t at = warnings.find("warning: skipping " + (dir / name).string() + ": ");
    EXPECT_NE(at, std::string::npos) << name << "\n" << warnings;
  }
  EXPECT_NE(warnings.find("checksum"), std::string::npos) << "the reason is given\n" << warnings;
  EXPECT_NE(warnings.find("type"), std::string::npos) << "the reason is given\n" << warnings;
  if (locked_unreadable) {
    EXPECT_NE(warnings.find("locked.nrrd"), std::string::npos) << warnings;
  }
  const nlohmann::json datasets = datasets_of(port);
  std::vector<std::string> names;
  for (const auto& d : datasets) names.push_back(d["slug"]);
  const std::vector<std::string> expected =
      locked_unreadable ? std::vector<std::string>{"good"} : std::vector<std::string>{"good", "locked"};
  EXPECT_EQ(names, expected);
  fs::permissions(dir / "locked.nrrd", fs::perms::owner_all);
}

// A folder in which nothing opens is an error naming the folder; a file named on the command
// line that does not open is an error as before (it was asked for by name).
TEST(CliServer, NothingLeftToServeIsAnError) {
  TempDir dir;
  make_volume(dir, "broken.strata");
  flip_byte(dir / "broken.strata", 20);
  std::string out;
  EXPECT_EQ(run_command("timeout 60 " + strata_cmd("serve " + shell_quoted(dir.path()) + " --port 0"), &out), 1) << out;
  EXPECT_NE(out.find("warning: skipping " + (dir / "broken.strata").string()), std::string::npos) << out;
  EXPECT_NE(out.find("error: nothing to serve: no volume file in " + dir.path().string() + " opens"), std::string::npos) << out;

  EXPECT_EQ(run_command("timeout 60 " + strata_cmd("serve " + shell_quoted(dir / "broken.strata") + " --port 0"), &out), 1)
      << out;
  EXPECT_NE(out.find("error: "), std::string::npos) << out;
  EXPECT_NE(out.find("broken.strata"), std::string::npos) << out;
  EXPECT_EQ(out.find("warning"), std::string::npos) << "a file named on the command line is not skipped\n" << out;
}

}  // namespace
}  // namespace strata::test
