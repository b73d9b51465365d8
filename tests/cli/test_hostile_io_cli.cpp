// Hostile volume files through the `strata` program: sizes that overflow, gzip bombs, kills
// while a gzip input is decoded, and messages that name the file and field (never library text).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cli/cli_test_util.hpp"
#include "support/test_support.hpp"

using strata::test::run_command;
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
