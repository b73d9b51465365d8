// `strata info`, `decompress` and `labels decode` on forged or damaged .strata files: exit code
// 1 and one `error: <file>: <field>: <problem>` line, never `null`, a JSON library message, a
// doubled file name or a crash.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>

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

  // A volume set of three different 12x10x8 time points (a 4-D NRRD written here), made once.
  static fs::path volume_set() {
    const fs::path set = *dir_ / "set.strata";
    if (fs::exists(set)) return set;
    const fs::path series = *dir_ / "series.nrrd";
    {
      std::ofstream out(series, std::ios::binary);
      out << "NRRD0004\ntype: uint16\ndimension: 4\nsizes: 12 10 8 3\nkinds: domain domain domain list\n"
             "endian: little\nencoding: raw\n\n";
      for (int t = 0; t < 3; ++t)
        for (int z = 0; z < 8; ++z)
          for (int y = 0; y < 10; ++y)
            for (int x = 0; x < 12; ++x) {
              const auto v = std::uint16_t(1000 * t + (t + 1) * (7 * x + 3 * y) + 11 * z);
              out.put(char(v & 0xff)).put(char(v >> 8));
            }
    }
    std::string out;
    EXPECT_EQ(run_command(strata_cmd("compress " + q(series) + " -o " + q(set) + " --all-volumes"), &out), 0) << out;
    return set;
  }

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

// Sections volume_1 and volume_2 of a volume set swapped in the metadata (its checksum fixed):
// `decompress --volume 1` wrote volume 2 and exited 0.
TEST_F(CliHostile, DecompressRefusesSwappedVolumes) {
  const fs::path p = edited(volume_set(), "swapped.strata",
                            [](nlohmann::json& m) { std::swap(m["sections"]["volume_1"], m["sections"]["volume_2"]); });
  for (const std::string volume : {"1", "2"}) {
    const std::string out = fails("decompress " + q(p) + " --volume " + volume + " -o " + q(*dir_ / "v.nrrd"));
    EXPECT_TRUE(has(out, "error: " + p.string() + ": section volume_" + volume + ": checksum mismatch")) << out;
  }
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("decompress " + q(p) + " --volume 0 -o " + q(*dir_ / "v.nrrd")), &out), 0) << out;
}

// A `normals` section with check value 0 was never compared: `render --lighting normals` lit the
// frame with it.
TEST_F(CliHostile, RenderRefusesANormalsSectionWithChecksumZero) {
  const fs::path lit = *dir_ / "lit.strata";
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("labels encode " + q(*dir_ / "v.nrrd") + " -o " + q(lit) + " --normals --no-error"), &out),
            0)
      << out;
  const fs::path p = edited(lit, "normals0.strata", [](nlohmann::json& m) { m["sections"]["normals"]["crc32c"] = 0; });
  out = fails("render " + q(p) + " --size 32x24 --lighting normals -o " + q(*dir_ / "n.png"));
  EXPECT_TRUE(has(out, "error: " + p.string() + ": section normals: checksum mismatch")) << out;
  EXPECT_FALSE(fs::exists(*dir_ / "n.png"));
}

// The index's min, max and histogram of a brick edited (index and header checksums fixed): they
// were under no check value, and the render changed (culling and ranges follow them).
TEST_F(CliHostile, EditedBrickRangesAreRefused) {
  const fs::path p = *dir_ / "ranges.strata";
  fs::copy_file(scalar(), p, fs::copy_options::overwrite_existing);
  const std::size_t n = strata::store::ContainerReader(scalar()).bricks().size();
  forge::rewrite_index_columns(p, [n](std::vector<std::byte>& c) {
    const std::size_t max = 26 * n, histogram = 30 * n;  // columns 8 and 9, byte planes
    c[max + 3 * n] ^= std::byte{0x01};                   // brick 0's max, its high byte
    for (std::size_t plane = 0; plane < 8; ++plane) c[histogram + plane * n] = std::byte{0xff};
  });
  for (const std::string& command : {std::string("info "), "render --size 32x24 -o " + q(*dir_ / "r.png") + " "}) {
    const std::string out = fails(command + q(p));
    EXPECT_TRUE(has(out, "error: " + p.string() + ": index: ") && has(out, "metadata.bricks_crc32c")) << command << out;
  }
}
