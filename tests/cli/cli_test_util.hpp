#pragma once
// Helpers shared by the tests that drive the built `strata` program.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "support/test_support.hpp"

namespace strata::test {

/// The command line that runs the built program with `args`, without progress output.
inline std::string strata_cmd(const std::string& args) {
  return std::string(STRATA_BINARY) + " --progress none " + args;
}

/// How a run of the built program ended: its exit code (-1 when it did not exit normally), the
/// signal that ended it (0 when none did), its own peak resident set (wait4's ru_maxrss) and the
/// bytes it caused to be written to storage (ru_oublock: file data it dirtied, on disk file
/// systems; tmpfs counts nothing), the program alone: no shell in between, and not the total of
/// every child the test process has had.
struct PeakRun {
  int exit_code = -1;
  int signal = 0;
  std::uint64_t peak_rss_bytes = 0;
  std::uint64_t written_bytes = 0;
};

/// Starts the built program with `args` (output discarded), `env` ("NAME=value") added to its
/// environment; returns its process id.
inline pid_t start_program(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
  std::vector<std::string> all{STRATA_BINARY, "--progress", "none"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<std::string> settings = env;
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    for (std::string& e : settings) ::putenv(e.data());
    std::freopen("/dev/null", "w", stdout);
    std::freopen("/dev/null", "w", stderr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

/// Waits for the program started as `pid` and says how it ended.
inline PeakRun wait_program(pid_t pid) {
  PeakRun run;
  int status = 0;
  rusage usage{};
  if (pid > 0 && ::wait4(pid, &status, 0, &usage) == pid) {
    if (WIFEXITED(status)) run.exit_code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) run.signal = WTERMSIG(status);
    run.peak_rss_bytes = std::uint64_t(usage.ru_maxrss) * 1024;  // kilobytes on Linux
    run.written_bytes = std::uint64_t(usage.ru_oublock) * 512;
  }
  return run;
}

/// Runs the built program with `args` (output discarded) and says how it ended (its peak memory,
/// what it wrote).
inline PeakRun run_measuring_peak(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
  return wait_program(start_program(args, env));
}

}  // namespace strata::test
