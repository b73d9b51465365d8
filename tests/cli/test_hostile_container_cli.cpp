// `strata info`, `decompress` and `labels decode` on forged or damaged .strata files: exit code
// 1 and one `error: <file>: <field>: <problem>` line, never `null`, a JSON library message, a
// doubled file name or a crash.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "store/forge.hpp"
#include "support/test_support.hpp"

using strata::test::run_command;
using strata::test::TempDir;
namespace fs = std::filesystem;
namespace forge = strata::test::forge;

namespace {

std::string strata_cmd(const std::string& args) { return std::string(STRATA_BINARY) + " --progress none " + args; }
std::string q(const fs::path& p) { return strata::test::shell_quoted(p); }
bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// prisms 40^3 compressed with the defaults, Voronoi 32^3 labels encoded with the defaults.
class CliHostile : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    std::string out;
    ASSERT_EQ(run_command(strata_cmd("generate prisms --size 40 -o " + q(*dir_ / "p.nrrd")), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("compress " + q(*dir_ / "p.nrrd") + " -o " + q(scalar())), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 32 -o " + q(*dir_ / "v.nrrd")), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("labels encode " + q(*dir_ / "v.nrrd") + " -o " + q(labels())), &out), 0) << out;
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path scalar() { return *dir_ / "p.strata"; }
  static fs::path labels() { return *dir_ / "v.strata"; }

  // A copy of `from` with its metadata edited and re-checksummed in place.
  static fs::path edited(const fs::path& from, const std::string& name, const std::function<void(nlohmann::json&)>& edit) {
    const fs::path p = *dir_ / name;
    fs::copy_file(from, p, fs::copy_options::overwrite_existing);
    forge::edit_metadata_in_place(p, edit);
    return p;
  }
  // Runs `args`; expects exit 1 and returns the output.
  static std::string fails(const std::string& args) {
    std::string out;
    EXPECT_EQ(run_command(strata_cmd(args), &out), 1) << args << "\n" << out;
    return out;
  }

  static inline TempDir* dir_ = nullptr;
};

}  // namespace

// `info` printed `null` and exited 0 when codec, levels or source was missing.
TEST_F(CliHostile, InfoNamesTheMissingField) {
  for (const fs::path& from : {scalar(), labels()})
    for (const std::string key : {"codec", "levels", "source"}) {
      const std::string name = from.stem().string() + "-no-" + key + ".strata";
      const fs::path p = edited(from, name, [&](nlohmann::json& m) { m.erase(key); });
      for (const std::string json : {"", "--json "}) {
        const std::string out = fails("info " + json + q(p));
        EXPECT_TRUE(has(out, "error: " + p.string() + ": metadata." + key + ": ")) << out;
        EXPECT_TRUE(has(out, "missing") || has(out, "expected")) << out;
        EXPECT_FALSE(has(out, "null")) << out;
      }
    }
}

// Wrong JSON types: one message naming the file and the field, not the JSON library's text.
TEST_F(CliHostile, WrongMetadataTypesAreNamedNotJsonLibraryText) {
  struct Case {
    fs::path from;
    std::string field;
    std::function<void(nlohmann::json&)> edit;
  };
  const std::vector<Case> cases{
      {scalar(), "metadata.rank", [](nlohmann::json& m) { m["rank"] = "sixteen"; }},
      {scalar(), "metadata.source.dims", [](nlohmann::json& m) { m["source"]["dims"][0] = -40; }},
      {scalar(), "metadata.levels[0].dims", [](nlohmann::json& m) { m["levels"][0]["dims"] = "40"; }},
      {scalar(), "metadata.sections", [](nlohmann::json& m) { m["sections"] = 3; }},
      {scalar(), "metadata.codec", [](nlohmann::json& m) { m["codec"] = 1; }},
      {labels(), "metadata.source.dims", [](nlohmann::json& m) { m["source"]["dims"] = nullptr; }},
      {labels(), "metadata.bits", [](nlohmann::json& m) { m["bits"] = "9"; }},
      {labels(), "metadata.sections.label_map.offset", [](nlohmann::json& m) { m["sections"]["label_map"]["offset"] = -1; }},
  };
  int i = 0;
  for (const Case& c : cases) {
    const fs::path p = edited(c.from, "types" + std::to_string(i++) + ".strata", c.edit);
    const std::string decode = c.from == scalar() ? "decompress -o " + q(*dir_ / "out.nrrd") + " "
                                                  : "labels decode --level 0 -o " + q(*dir_ / "out.nrrd") + " ";
    for (const std::string& command : {std::string("info "), decode}) {
      const std::string out = fails(command + q(p));
      EXPECT_TRUE(has(out, "error: " + p.string() + ": " + c.field + ": ")) << command << c.field << "\n" << out;
      EXPECT_FALSE(has(out, "json.exception") || has(out, "type must be")) << out;
    }
  }
}

// `decompress` accepted spacing <= 0 and wrote it to the output.
TEST_F(CliHostile, DecompressRefusesBadSpacing) {
  const fs::path p = edited(scalar(), "spacing.strata", [](nlohmann::json& m) { m["source"]["spacing"][1] = -1.0; });
  const std::string out = fails("decompress " + q(p) + " -o " + q(*dir_ / "s.nrrd"));
  // The metadata edit alone fails the metadata check (spacing) before any payload is read.
  EXPECT_TRUE(has(out, "error: " + p.string() + ": metadata.source.spacing: expected an array of 3 finite numbers > 0")) << out;
}

// overlap 2 -> 3 (the same brick grids) decoded silently with the wrong geometry.
TEST_F(CliHostile, DecompressRefusesMetadataEditedUnderThePayloads) {
  const fs::path p = edited(scalar(), "overlap.strata", [](nlohmann::json& m) { m["overlap"] = 3; });
  const std::string out = fails("decompress " + q(p) + " -o " + q(*dir_ / "o.nrrd"));
  EXPECT_TRUE(has(out, "error: " + p.string() + ": brick (level ") && has(out, "payload checksum mismatch")) << out;
}

// A damaged zstd payload behind a valid checksum: the file is named once (it was named twice).
TEST_F(CliHostile, CorruptPayloadNamesTheFileOnce) {
  const fs::path p = *dir_ / "zstd.strata";
  forge::rewrite(scalar(), p, nullptr, [](std::vector<forge::Brick>& bricks) {
    for (auto& b : bricks)
      if (b.entry.kind == strata::store::PayloadKind::tucker_zstd) b.payload.resize(b.payload.size() / 2);  // a cut frame
  });
  const std::string out = fails("decompress " + q(p) + " -o " + q(*dir_ / "z.nrrd"));
  EXPECT_TRUE(has(out, "error: " + p.string() + ": brick (level ")) << out;
  EXPECT_EQ(out.find(p.string()), out.rfind(p.string())) << out;
}

// Truncated files: exit 1 with a message naming the file (no crash, no hang).
TEST_F(CliHostile, TruncatedFilesFailCleanly) {
  for (const fs::path& from : {scalar(), labels()}) {
    const auto bytes = forge::file_bytes(from);
    for (const std::size_t size : {std::size_t(0), std::size_t(10), std::size_t(64), bytes.size() / 2, bytes.size() - 1}) {
      const fs::path p = *dir_ / "cut.strata";
      forge::write_file(p, std::span(bytes).first(size));
      const std::string out = fails("info " + q(p));
      EXPECT_TRUE(has(out, "error: " + p.string() + ": ")) << size << ": " << out;
    }
  }
}
