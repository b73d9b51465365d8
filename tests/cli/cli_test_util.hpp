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

/// What run_measuring_peak saw: the exit code (-1 when the program did not exit normally) and
/// the program's own peak resident set (wait4's ru_maxrss), in bytes.
struct PeakRun {
  int exit_code = -1;
  std::uint64_t peak_rss_bytes = 0;
};

/// Runs the built program with `args` (output discarded) and measures its peak memory alone:
/// no shell in between, and not the maximum over every child the test process has had.
inline PeakRun run_measuring_peak(const std::vector<std::string>& args) {
  std::vector<std::string> all{STRATA_BINARY, "--progress", "none"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::freopen("/dev/null", "w", stdout);
    std::freopen("/dev/null", "w", stderr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  PeakRun run;
  int status = 0;
  rusage usage{};
  if (pid > 0 && ::wait4(pid, &status, 0, &usage) == pid) {
    if (WIFEXITED(status)) run.exit_code = WEXITSTATUS(status);
    run.peak_rss_bytes = std::uint64_t(usage.ru_maxrss) * 1024;  // kilobytes on Linux
  }
  return run;
}

}  // namespace strata::test
