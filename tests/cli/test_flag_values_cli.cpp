// Every option that takes a value, of every command: an empty value was read by CLI11 as "not
// given" or 0 (`compress --psnr ''` wrote a fixed-rank file). The options are read from each
// command's --help, so a new option is covered without an edit here.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_test_util.hpp"
#include "support/test_support.hpp"

using strata::test::run_command;
using strata::test::strata_cmd;

namespace {

namespace fs = std::filesystem;

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// ---------------------------------------------------------------------------------------------
// Every value flag of every command refuses an empty value.

// A flag or positional as `--help` lists it: its name, and whether it is a positional.
struct ValueOption {
  std::string name;
  bool positional = false;
};

// The options of `command` (e.g. "labels encode"; "" for the program's own) that take a value,
// read from its --help: "  --psnr FLOAT ...", "  -o,--output TEXT REQUIRED", "  input TEXT";
// flags ("  --json   Print JSON") have no type after the name.
std::vector<ValueOption> value_options(const std::string& command) {
  std::string help;
  EXPECT_EQ(run_command(strata_cmd(command + " --help"), &help), 0) << help;
  std::vector<ValueOption> options;
  static const std::regex line(R"(^  (\S+) ([A-Z][A-Z0-9_]*)([:= ].*)?$)");
  bool positionals = false;
  std::istringstream in(help);
  for (std::string text; std::getline(in, text);) {
    if (!text.empty() && text[0] != ' ') positionals = text.starts_with("Positionals:");
    std::smatch m;
    if (!std::regex_match(text, m, line)) continue;
    // The name CLI11 reports: the first long name ("-o,--output" -> "--output").
    std::string name = m[1].str();
    std::string first_long;
    std::istringstream names(name);
    for (std::string n; std::getline(names, n, ',');)
      if (first_long.empty() && n.starts_with("--")) first_long = n;
    options.push_back({first_long.empty() ? name : first_long, positionals});
  }
  return options;
}

class EmptyFlagValues : public ::testing::TestWithParam<const char*> {};

// `compress --psnr ''` wrote a fixed-rank file, `--rank ''` meant the default: CLI11 reads an
// empty value as "not given" or 0. Every option that takes a value must refuse it (exit 2).
TEST_P(EmptyFlagValues, EveryValueFlagRefusesAnEmptyValue) {
  const std::string command = GetParam();
  const std::vector<ValueOption> options = value_options(command);
  ASSERT_FALSE(options.empty()) << "no value options found in `strata " << command << " --help`";
  int positional_index = 0;
  for (const ValueOption& option : options) {
    std::string args;
    if (option.positional) {
      // Earlier positionals get a value, so the empty one is this one.
      for (int i = 0; i < positional_index; ++i) args += " x";
      args += " ''";
      ++positional_index;
    } else {
      args = " " + option.name + " ''";
    }
    // The program's own options come before a subcommand.
    const std::string line = command.empty() ? args + " info x" : command + args;
    std::string out;
    EXPECT_EQ(run_command(strata_cmd(line), &out), 2) << line << "\n" << out;
    EXPECT_TRUE(has(out, "error: " + option.name + ": expected ")) << line << "\n" << out;
    EXPECT_TRUE(has(out, "got an empty value")) << line << "\n" << out;
  }
}

INSTANTIATE_TEST_SUITE_P(Commands, EmptyFlagValues,
                         ::testing::Values("", "info", "convert", "generate", "compare", "compress",
                                           "decompress", "eval", "labels encode", "labels decode", "labels query",
                                           "labels palette", "labels calibrate", "render", "serve", "demo"),
                         [](const ::testing::TestParamInfo<const char*>& info) {
                           std::string name = *info.param ? info.param : "program";
                           for (char& c : name)
                             if (c == ' ') c = '_';
                           return name;
                         });

// What a flag expects is named, for an empty value and for one of the wrong kind (Strata's words,
// not CLI11's "Could not convert: --rank = abc"); integers are decimal (CLI11 read "0x10" as 16
// and "010" as octal 8).
TEST(FlagValueSyntax, TheMessageNamesWhatTheFlagExpects) {
  const std::pair<const char*, const char*> cases[] = {
      {"compress in.nrrd -o out.strata --psnr ''", "error: --psnr: expected a number, got an empty value"},
      {"compress in.nrrd -o out.strata --rank ''", "error: --rank: expected an integer, got an empty value"},
      {"--progress '' info x", "error: --progress: expected one of {auto,bar,json,none}, got an empty value"},
      {"compress in.nrrd -o out.strata --rank abc", "error: --rank: expected an integer, got 'abc'"},
      {"compress in.nrrd -o out.strata --psnr 40dB", "error: --psnr: expected a number, got '40dB'"},
      {"compress in.nrrd -o out.strata --brick 0x10", "error: --brick: expected an integer, got '0x10'"},
      {"labels query in.strata --max-samples -1", "error: --max-samples: expected a non-negative integer, got '-1'"},
  };
  for (const auto& [args, message] : cases) {
    std::string out;
    EXPECT_EQ(run_command(strata_cmd(args), &out), 2) << args << "\n" << out;
    EXPECT_TRUE(has(out, message)) << args << "\n" << out;
    EXPECT_FALSE(has(out, "Could not convert")) << args << "\n" << out;
  }
}

}  // namespace
