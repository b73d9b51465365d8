// Hostile volume files through the `strata` program: sizes that overflow, gzip bombs, gzip inputs
// that must stream instead of filling TMPDIR, kills while a gzip input is decoded or a volume set
// is written, and messages that name the file and field (never library text).
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "cli/cli_test_util.hpp"
#include "support/test_support.hpp"

using strata::test::PeakRun;
using strata::test::run_command;
using strata::test::run_measuring_peak;
using strata::test::start_program;
using strata::test::wait_program;
using strata::test::strata_cmd;
using strata::test::shell_quoted;
using strata::test::TempDir;

namespace {

namespace fs = std::filesystem;


void write_file(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

std::size_t entries(const fs::path& dir) {
  return std::size_t(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}));
}

// Runs `strata args` (under a time limit, so a hang fails instead of blocking the suite) and
// expects exit code 1 with an error naming every one of `parts` and no library text.
void expect_failure(const std::string& args, const std::vector<std::string>& parts) {
  SCOPED_TRACE(args);
  std::string out;
  EXPECT_EQ(run_command("timeout -s KILL 60 " + strata_cmd(args), &out), 1) << out;
  EXPECT_EQ(out.rfind("error: ", 0), 0u) << out;
  for (const auto& part : parts) EXPECT_NE(out.find(part), std::string::npos) << "\"" << part << "\" missing: " << out;
  for (const char* library_text : {"bad_alloc", "json.exception", "_M_range_check", "type must be"})
    EXPECT_EQ(out.find(library_text), std::string::npos) << out;
}

const std::string kWrapping = "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 4611686018427387904 4 1\nendian: little\n"
                              "encoding: raw\n\n";

}  // namespace

TEST(CliHostileIo, SizesThatOverflowFailInsteadOfReadingNothing) {
  TempDir dir;
  write_file(dir / "z.nrrd", kWrapping);
  expect_failure("info " + shell_quoted(dir / "z.nrrd"), {"z.nrrd", "sizes"});
  expect_failure("convert " + shell_quoted(dir / "z.nrrd") + " " + shell_quoted(dir / "out.nrrd"), {"z.nrrd", "sizes"});
  EXPECT_FALSE(fs::exists(dir / "out.nrrd"));
  EXPECT_FALSE(fs::exists(dir / "out.nrrd.tmp"));
  // These sizes used to stream 2^40 empty slices (a hang).
  write_file(dir / "h.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4294967296 4294967296 1099511627776\n"
                             "encoding: raw\n\n");
  expect_failure("info " + shell_quoted(dir / "h.nrrd"), {"h.nrrd", "sizes"});
  write_file(dir / "r.raw", "x");
  write_file(dir / "r.raw.json", R"({"dims":[4294967296,4294967296,4294967296],"dtype":"u16"})");
  expect_failure("info " + shell_quoted(dir / "r.raw"), {"r.raw.json", "dims"});
}

TEST(CliHostileIo, GzipBombStopsAtTheDeclaredSize) {
  TempDir dir, temp;
  // 8x8x8 u8 declared; 64 MiB of zeros in the stream.
  ASSERT_EQ(run_command("head -c 67108864 /dev/zero | gzip -1 > " + shell_quoted(dir / "zeros.gz")), 0);
  write_file(dir / "bomb.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: gzip\n\n");
  ASSERT_EQ(run_command("cat " + shell_quoted(dir / "zeros.gz") + " >> " + shell_quoted(dir / "bomb.nrrd")), 0);
  expect_failure("info " + shell_quoted(dir / "bomb.nrrd") + "", {"bomb.nrrd", "data", "more than the 512 bytes"});
  std::string out;
  EXPECT_EQ(run_command("TMPDIR=" + shell_quoted(temp.path()) + " " + strata_cmd("info " + shell_quoted(dir / "bomb.nrrd")),
                        &out),
            1);
  EXPECT_EQ(entries(temp.path()), 0u);
}

// Whenever a kill lands (while decoding, while reading the decoded data or after), no decoded
// temporary is left in TMPDIR.
TEST(CliHostileIo, KilledWhileDecodingLeavesNoTemporary) {
  TempDir dir, temp;
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate marschner-lobb --size 256 -o " + shell_quoted(dir / "big.nrrd")), &out), 0)
      << out;
  const std::string env = "TMPDIR=" + shell_quoted(temp.path()) + " ";
  for (const char* signal : {"KILL", "TERM", "INT"}) {
    for (const char* delay : {"0.02", "0.1", "0.3", "0.6"}) {
      SCOPED_TRACE(std::string(signal) + " after " + delay + " s");
      run_command(env + "timeout -s " + signal + " " + delay + " " + strata_cmd("info " + shell_quoted(dir / "big.nrrd")),
                  &out);
      EXPECT_EQ(entries(temp.path()), 0u);
    }
  }
  // And a run that finishes reads the data and leaves nothing either.
  EXPECT_EQ(run_command(env + strata_cmd("info " + shell_quoted(dir / "big.nrrd")), &out), 0) << out;
  EXPECT_EQ(entries(temp.path()), 0u);
}

TEST(CliHostileIo, MessagesNameTheFileAndField) {
  TempDir dir;
  write_file(dir / "x.strata", "");
  expect_failure("info " + shell_quoted(dir / "x.strata"), {"x.strata: empty file (0 bytes), expected a .strata container"});
  write_file(dir / "s.raw", std::string(8, 'x'));
  write_file(dir / "s.raw.json", R"({"dims":["2","2","2"],"dtype":"u8"})");
  expect_failure("info " + shell_quoted(dir / "s.raw"), {"s.raw.json", "dims", "positive integers"});
  write_file(dir / "s.raw.json", R"({"dims":[2,2,2],"dtype":"u8","spacing":[1,"a",1]})");
  expect_failure("info " + shell_quoted(dir / "s.raw"), {"s.raw.json", "spacing"});
  write_file(dir / "s.raw.json", R"({"dims":[2,2,2],"dtype":"u8","header_bytes":-4})");
  expect_failure("info " + shell_quoted(dir / "s.raw"), {"s.raw.json", "header_bytes"});
  write_file(dir / "sp.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nspacings: 1 -1 1\nencoding: raw\n\nx");
  expect_failure("info " + shell_quoted(dir / "sp.nrrd"), {"sp.nrrd", "spacings"});
}

// Passes in z order decode a gzip input as they go: `info`, `convert` and `compress` need no
// temporary file (they run with a TMPDIR that does not exist), and a small gzip file that
// declares more than it holds fails at the end of its stream without writing what it decoded.
TEST(CliHostileIo, GzipInputsStreamWithoutATemporary) {
  TempDir dir, temp;
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate marschner-lobb --size 40 -o " + shell_quoted(dir / "g.nrrd")), &out), 0)
      << out;
  ASSERT_EQ(run_command(strata_cmd("convert " + shell_quoted(dir / "g.nrrd") + " " + shell_quoted(dir / "g.nii.gz")),
                        &out),
            0)
      << out;
  const std::vector<std::string> nowhere{"TMPDIR=" + (dir / "missing").string()};
  for (const char* name : {"g.nrrd", "g.nii.gz"}) {
    SCOPED_TRACE(name);
    const std::string in = (dir / name).string();
    EXPECT_EQ(run_measuring_peak({"info", in}, nowhere).exit_code, 0);
    EXPECT_EQ(run_measuring_peak({"convert", in, (dir / "c.raw").string()}, nowhere).exit_code, 0);
    EXPECT_EQ(run_measuring_peak({"compress", in, "--brick", "16", "-o", (dir / "c.strata").string()}, nowhere).exit_code,
              0);
  }
  // 1024 x 1024 x 128 bytes declared, 64 MiB of zeros (64 KiB of gzip) in the stream.
  ASSERT_EQ(run_command("head -c 67108864 /dev/zero | gzip -1 > " + shell_quoted(dir / "zeros.gz")), 0);
  write_file(dir / "short.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1024 1024 128\nencoding: gzip\n\n");
  ASSERT_EQ(run_command("cat " + shell_quoted(dir / "zeros.gz") + " >> " + shell_quoted(dir / "short.nrrd")), 0);
  for (const char* command : {"info", "compress"}) {
    SCOPED_TRACE(command);
    std::vector<std::string> args{command, (dir / "short.nrrd").string()};
    if (std::string(command) == "compress") args.insert(args.end(), {"-o", (dir / "short.strata").string()});
    const PeakRun run = run_measuring_peak(args, {"TMPDIR=" + temp.path().string()});
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_LT(run.written_bytes, std::uint64_t(16) << 20);  // decoding to TMPDIR wrote all 64 MiB
    EXPECT_EQ(entries(temp.path()), 0u);
  }
  expect_failure("info " + shell_quoted(dir / "short.nrrd"), {"short.nrrd", "data", "67108864 bytes", "truncated"});
  EXPECT_FALSE(fs::exists(dir / "short.strata"));
}

namespace {

// The entries of `dir` whose names start with a dot or end with .tmp: what a stopped run leaves.
std::vector<std::string> leftovers(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.starts_with(".") || name.ends_with(".tmp")) names.push_back(name);
  }
  return names;
}

// Waits until `dir` holds a member of the volume set `output` (".<output>.volumeN.part"), so a
// signal lands while the next member is encoded; false when the run ends first.
bool wait_for_member(pid_t pid, const fs::path& dir, const std::string& output) {
  const std::string prefix = "." + output + ".volume";
  for (int i = 0; i < 24000; ++i) {
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string name = e.path().filename().string();
      if (name.starts_with(prefix) && name.ends_with(".part")) return true;
    }
    if (::waitpid(pid, nullptr, WNOHANG) != 0) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

}  // namespace

// `compress --all-volumes` encodes each volume into a hidden member beside the output. A run
// stopped by SIGTERM or SIGINT removes them (and its .tmp files) before it ends by that signal;
// SIGKILL cannot be caught, and the next run writing the same output removes what it left.
TEST(CliHostileIo, StoppedAllVolumesRunLeavesNoMembers) {
  TempDir dir;
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate marschner-lobb --size 96 -o " + shell_quoted(dir / "one.raw")), &out), 0)
      << out;
  std::ifstream one(dir / "one.raw", std::ios::binary);
  const std::string samples((std::istreambuf_iterator<char>(one)), std::istreambuf_iterator<char>());
  ASSERT_EQ(samples.size(), std::size_t(96 * 96 * 96 * 4));
  std::string series = "NRRD0004\ntype: float\ndimension: 4\nsizes: 96 96 96 6\nkinds: domain domain domain list\n"
                       "endian: little\nencoding: raw\n\n";
  for (int t = 0; t < 6; ++t) series += samples;
  fs::remove(dir / "one.raw");
  fs::remove(dir / "one.raw.json");
  write_file(dir / "series.nrrd", series);
  const std::vector<std::string> args{"--threads", "1", "compress", (dir / "series.nrrd").string(), "--all-volumes",
                                      "--brick", "16", "-o", (dir / "set.strata").string()};
  for (const int sig : {SIGTERM, SIGINT}) {
    SCOPED_TRACE(sig);
    const pid_t pid = start_program(args);
    ASSERT_TRUE(wait_for_member(pid, dir.path(), "set.strata")) << "the run ended before its first member was written";
    ::kill(pid, sig);
    const PeakRun run = wait_program(pid);
    EXPECT_EQ(run.signal, sig);  // it still ends by the signal
    EXPECT_EQ(leftovers(dir.path()), std::vector<std::string>{});
    EXPECT_FALSE(fs::exists(dir / "set.strata"));
  }
  // SIGKILL leaves the members; the next run of the same output removes them, and those of an
  // earlier run with more volumes.
  const pid_t pid = start_program(args);
  ASSERT_TRUE(wait_for_member(pid, dir.path(), "set.strata"));
  ::kill(pid, SIGKILL);
  wait_program(pid);
  EXPECT_FALSE(leftovers(dir.path()).empty());
  write_file(dir / ".set.strata.volume17.part", "stale");
  EXPECT_EQ(run_measuring_peak(args).exit_code, 0);
  EXPECT_EQ(leftovers(dir.path()), std::vector<std::string>{});
  EXPECT_TRUE(fs::exists(dir / "set.strata"));
}
