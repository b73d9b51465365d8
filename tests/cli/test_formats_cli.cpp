// `strata formats` and the format lists of `strata convert --help` and the README: all of them
// come from the format registry, so they list exactly the registered formats.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "cli/cli_test_util.hpp"
#include "strata/io/formats.hpp"
#include "support/test_support.hpp"

namespace strata {
namespace {

using test::run_command;
using test::strata_cmd;

std::string output_of(const std::string& args, int expected_code = 0) {
  std::string out;
  EXPECT_EQ(run_command(strata_cmd(args), &out), expected_code) << args << ": " << out;
  return out;
}

// The table of README.md's "### Formats" section: its lines that start with '|'.
std::string readme_format_table() {
  const std::filesystem::path readme =
      std::filesystem::path(STRATA_TEST_DATA_DIR).parent_path().parent_path() / "README.md";
  std::ifstream in(readme);
  EXPECT_TRUE(in) << readme;
  std::string line, table;
  bool in_section = false;
  while (std::getline(in, line)) {
    if (line.starts_with("#")) in_section = line == "### Formats";
    else if (in_section && line.starts_with("|")) table += line + "\n";
  }
  return table;
}

TEST(CliFormats, ListsEveryRegisteredFormatWithItsExtensions) {
  const std::string out = output_of("formats");
  for (const io::VolumeFormat* f : io::formats()) {
    EXPECT_NE(out.find(f->name), std::string::npos) << f->name << "\n" << out;
    EXPECT_NE(out.find(f->description), std::string::npos) << f->name << "\n" << out;
    for (const std::string& ext : f->extensions) EXPECT_NE(out.find(ext), std::string::npos) << ext << "\n" << out;
  }
  EXPECT_NE(out.find("all but i8"), std::string::npos) << out;  // what NIfTI writes
}

TEST(CliFormats, JsonDescribesWhatEachFormatCanDo) {
  const nlohmann::json j = nlohmann::json::parse(output_of("formats --json"));
  const std::vector<const io::VolumeFormat*> all = io::formats();
  ASSERT_EQ(j["formats"].size(), all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    const nlohmann::json& f = j["formats"][i];
    EXPECT_EQ(f["name"], all[i]->name);
    EXPECT_EQ(f["extensions"].get<std::vector<std::string>>(), all[i]->extensions);
    EXPECT_EQ(f["multi_volume"], all[i]->capabilities.multi_volume);
    EXPECT_EQ(f["streaming"], all[i]->capabilities.streaming);
    EXPECT_EQ(f["spatial_metadata"], all[i]->capabilities.spatial_metadata);
    if (all[i]->create_writer)
      EXPECT_EQ(f["write"]["dtypes"].size(), all[i]->write_dtypes.list().size());
    else
      EXPECT_TRUE(f["write"].is_null()) << all[i]->name << ": a read-only format has no \"write\"";
  }
  const nlohmann::json& nifti = j["formats"][2];
  ASSERT_EQ(nifti["name"], "nifti");
  EXPECT_EQ(nifti["write"]["label_dtypes"], (nlohmann::json{"u8", "u16", "i16", "u32", "i32", "u64", "i64"}));
  EXPECT_EQ(j["formats"][0]["directory"], nullptr);
  EXPECT_EQ(j["formats"][3]["directory"], "a directory of TIFF slices");
}

// The README's table is what `strata formats --markdown` prints: regenerate it with that
// command when a format changes, and this test keeps the two from drifting apart.
TEST(CliFormats, ReadmeTableIsWhatMarkdownPrints) {
  EXPECT_EQ(readme_format_table(), output_of("formats --markdown"))
      << "README.md's \"### Formats\" table is stale: replace it with the output of `strata formats --markdown`";
}

TEST(CliFormats, JsonAndMarkdownExcludeEachOther) { output_of("formats --json --markdown", 2); }

TEST(CliFormats, ConvertHelpListsTheRegisteredFormats) {
  const std::string help = output_of("convert --help");
  for (const io::VolumeFormat* f : io::formats()) {
    EXPECT_NE(help.find(f->title), std::string::npos) << f->title << "\n" << help;
    for (const std::string& ext : f->extensions) EXPECT_NE(help.find(ext), std::string::npos) << ext << "\n" << help;
  }
}

TEST(CliFormats, UnknownOutputExtensionsAreUsageErrorsListingTheFormats) {
  test::TempDir dir;
  output_of("generate prisms --size 8 -o " + test::shell_quoted(dir / "in.nrrd"));
  const std::string out = output_of("convert " + test::shell_quoted(dir / "in.nrrd") + " " +
                                        test::shell_quoted(dir / "out.xyz"),
                                    2);
  EXPECT_NE(out.find("out.xyz"), std::string::npos) << out;
  EXPECT_NE(out.find(io::known_extensions_text()), std::string::npos) << out;
}

}  // namespace
}  // namespace strata
