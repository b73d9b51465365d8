// Forged ta-bricked files whose container checksums are valid: every inconsistency between the
// metadata, the index and the payloads is a FormatError naming the file and the field or brick,
// never a silent decode with the wrong geometry.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "strata/store/container.hpp"
#include "strata/ta/target_codec.hpp"
#include "store/forge.hpp"
#include "ta/ta_test_util.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;
namespace fs = std::filesystem;
namespace forge = strata::test::forge;

namespace {

// 30x30x30 prisms, brick 16, overlap 2 (core 12), rank 8: 3x3x3 + 2x2x2 + 1 bricks. With
// overlap 3 (core 10) the octree has the same levels and brick grids, so only the payloads'
// checksums can tell the two apart.
class TaForgedFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    compress(prisms({30, 30, 30}, 4), good(), params(16, 2, 8, "u16,b8log+"));
    CompressParams coded = params(16, 2, 16, "u16,b8log+");
    coded.codec.target = {TargetKind::psnr, 40};
    compress(prisms({30, 30, 30}, 4), good_coded(), coded);
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path good() { return *dir_ / "good.strata"; }
  static fs::path good_coded() { return *dir_ / "coded.strata"; }

  static fs::path copy(const std::string& name, const fs::path& from = good()) {
    const fs::path p = *dir_ / name;
    fs::copy_file(from, p, fs::copy_options::overwrite_existing);
    return p;
  }
  // The metadata edited in place and re-checksummed (the container accepts it).
  static fs::path edited(const std::string& name, const std::function<void(nlohmann::json&)>& edit) {
    const fs::path p = copy(name);
    forge::edit_metadata_in_place(p, edit);
    return p;
  }
  // A copy written through ContainerWriter: every checksum valid, payload bindings included.
  static fs::path rewritten(const std::string& name, const std::function<void(nlohmann::json&)>& edit,
                            const std::function<void(std::vector<forge::Brick>&)>& bricks = nullptr,
                            const fs::path& from = good()) {
    const fs::path p = *dir_ / name;
    forge::rewrite(from, p, edit, bricks);
    return p;
  }

  // What opening and decoding every level throws (forge::failure_of).
  static std::string open_and_decode(const fs::path& p) {
    return forge::failure_of([&] {
      TaVolume t(p);
      for (int l = 0; l < t.geometry().level_count(); ++l) t.decode_box(l, Box::whole(t.geometry().level(l).dims), t.rank());
    });
  }

  static inline test::TempDir* dir_ = nullptr;
};

}  // namespace

// overlap 2 -> 3, rank 8 -> 4, source.dims 30 -> 31 in the JSON, re-checksummed: each decoded
// silently with the wrong geometry or rank. Now the levels do not fit (dims) or the payloads'
// checksums, which cover the metadata, fail naming the brick.
TEST_F(TaForgedFiles, GeometryEditedInTheMetadataIsRefused) {
  std::string msg = open_and_decode(edited("overlap.strata", [](nlohmann::json& m) { m["overlap"] = 3; }));
  EXPECT_TRUE(contains(msg, "overlap.strata: brick (level ") && contains(msg, "payload checksum mismatch")) << msg;
  msg = open_and_decode(edited("rank.strata", [](nlohmann::json& m) { m["rank"] = 4; }));
  EXPECT_TRUE(contains(msg, "rank.strata: brick (level ") && contains(msg, "payload checksum mismatch")) << msg;
  msg = open_and_decode(edited("dims.strata", [](nlohmann::json& m) { m["source"]["dims"] = {31, 30, 30}; }));
  EXPECT_TRUE(contains(msg, "dims.strata: metadata.levels[0].dims: expected [31, 30, 30]")) << msg;
  // Informative fields under the payloads fail too (the checksum covers the whole metadata).
  msg = open_and_decode(edited("zstd.strata", [](nlohmann::json& m) { m["zstd_level"] = 9; }));
  EXPECT_TRUE(contains(msg, "zstd.strata: brick (level ") && contains(msg, "payload checksum mismatch")) << msg;
}

// Fields that contradict each other or the index, with every checksum valid.
TEST_F(TaForgedFiles, MetadataIsCheckedAgainstItselfAndTheIndex) {
  struct Case {
    std::string expect;
    std::function<void(nlohmann::json&)> edit;
  };
  const std::vector<Case> cases{
      {"metadata.codec_version: expected an integer in [1, 1], got 2", [](nlohmann::json& m) { m["codec_version"] = 2; }},
      {"metadata.codec_version: missing", [](nlohmann::json& m) { m.erase("codec_version"); }},
      {"metadata.source.spacing: expected an array of 3 finite numbers > 0, got array [1.0,0,1.0]",
       [](nlohmann::json& m) { m["source"]["spacing"][1] = 0; }},
      {"metadata.source.spacing: expected an array of 3 finite numbers > 0, got array [-1,1.0,1.0]",
       [](nlohmann::json& m) { m["source"]["spacing"][0] = -1; }},
      // NaN has no JSON spelling; nlohmann writes it as null.
      {"metadata.source.spacing: expected an array of 3 finite numbers > 0, got array [1.0,1.0,null]",
       [](nlohmann::json& m) { m["source"]["spacing"][2] = std::nan(""); }},
      {"metadata.source.value_range: expected [min, max] with min <= max", [](nlohmann::json& m) { m["source"]["value_range"] = {5, 1}; }},
      {"metadata.source.dims: expected an array of 3 integers in [1, 2147483647], got array [30.5,30,30]",
       [](nlohmann::json& m) { m["source"]["dims"][0] = 30.5; }},
      {"metadata.rank: expected an integer in [1, 16], got number 8.5", [](nlohmann::json& m) { m["rank"] = 8.5; }},
      {"metadata.overlap: expected an integer in [0, 127], got boolean true", [](nlohmann::json& m) { m["overlap"] = true; }},
      {"metadata.levels[1].bricks: expected [2, 2, 2]", [](nlohmann::json& m) { m["levels"][1]["bricks"] = {2, 2, 1}; }},
      {"metadata.levels[2].dims: expected [8, 8, 8]", [](nlohmann::json& m) { m["levels"][2]["dims"] = {8, 8, 9}; }},
      {"metadata.levels[1]: expected an object with the key \"dims\"", [](nlohmann::json& m) { m["levels"][1] = 5; }},
      {"metadata.levels: expected 3 levels", [](nlohmann::json& m) { m["levels"].push_back(m["levels"][2]); }},
      {"metadata.target: missing", [](nlohmann::json& m) { m["quant"] = "coded"; }},
      // quant says coded, the payloads' kinds say fixed-rank.
      {"does not belong in a file with quant \"coded\"",
       [](nlohmann::json& m) {
         m["quant"] = "coded";
         m["target"] = nlohmann::json::object();
       }},
  };
  int i = 0;
  for (const Case& c : cases) {
    const std::string name = "case" + std::to_string(i++) + ".strata";
    const std::string msg = open_and_decode(rewritten(name, c.edit));
    EXPECT_TRUE(contains(msg, name + ": ")) << c.expect << "\n" << msg;
    EXPECT_TRUE(contains(msg, c.expect)) << c.expect << "\n" << msg;
    EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ") || contains(msg, "json.exception")) << msg;
  }
}

TEST_F(TaForgedFiles, IndexMustHoldExactlyTheOctreesBricks) {
  using Bricks = std::vector<forge::Brick>;
  std::string msg = open_and_decode(rewritten("missing.strata", nullptr, [](Bricks& b) { b.erase(b.begin() + 5); }));
  EXPECT_TRUE(contains(msg, "missing.strata: index: brick (level 0, ") && contains(msg, "is missing: level 0 has 26 bricks, its grid [3, 3, 3] needs 27"))
      << msg;
  msg = open_and_decode(rewritten("outside.strata", nullptr, [](Bricks& b) { b.back().entry.key.x = 1; }));
  EXPECT_TRUE(contains(msg, "outside.strata: index: brick (level 2, 1,0,0) lies outside the level's brick grid [1, 1, 1]")) << msg;
  msg = open_and_decode(rewritten("deeper.strata", nullptr, [](Bricks& b) { b.back().entry.key.level = 7; }));
  EXPECT_TRUE(contains(msg, "deeper.strata: index: brick (level 7, 0,0,0) lies past the last level 2")) << msg;
  // A raw_zstd brick has no place in a fixed-rank file.
  msg = open_and_decode(rewritten("kind.strata", nullptr, [](Bricks& b) {
    for (auto& x : b)
      if (x.entry.kind != store::PayloadKind::constant) {
        x.entry.kind = store::PayloadKind::raw_zstd;
        break;
      }
  }));
  EXPECT_TRUE(contains(msg, "kind.strata: brick (level") && contains(msg, "payload kind raw_zstd does not belong")) << msg;
  // A Tucker brick with no payload bytes.
  msg = open_and_decode(rewritten("empty.strata", nullptr, [](Bricks& b) {
    for (auto& x : b)
      if (x.entry.kind != store::PayloadKind::constant) {
        x.payload.clear();
        break;
      }
  }));
  EXPECT_TRUE(contains(msg, "empty.strata: brick (level") && contains(msg, "needs payload bytes")) << msg;
}

// Garbage payloads with valid checksums (forged) of every kind: one message naming the file
// once and the brick, never a crash, a hang or the file name twice.
TEST_F(TaForgedFiles, GarbagePayloadsNameTheFileOnceAndTheBrick) {
  std::mt19937 rng(5);
  for (const fs::path& from : {good(), good_coded()}) {
    for (int trial = 0; trial < 6; ++trial) {
      const std::string name = from.stem().string() + "-garbage" + std::to_string(trial) + ".strata";
      const fs::path p = rewritten(name, nullptr, [&](std::vector<forge::Brick>& b) {
        for (auto& x : b) {
          if (x.payload.empty()) continue;
          if (trial % 2 == 0) {
            for (auto& byte : x.payload) byte = std::byte(rng());
          } else {
            x.payload.resize(std::size_t(rng() % x.payload.size()));  // truncated payloads
            if (x.payload.empty()) x.payload.push_back(std::byte{1});
          }
        }
      }, from);
      const std::string msg = open_and_decode(p);
      EXPECT_TRUE(contains(msg, name + ": brick (level")) << msg;
      EXPECT_EQ(msg.find(name), msg.rfind(name)) << "file named twice: " << msg;
      EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "_M_range_check")) << msg;
    }
  }
}

// A file written with the 1.2 rule (payload checksums of the bytes alone) still opens and
// decodes to the same samples.
TEST_F(TaForgedFiles, Format12FilesStillDecode) {
  for (const fs::path& from : {good(), good_coded()}) {
    const fs::path old = copy(from.stem().string() + "-v12.strata", from);
    forge::downgrade_to_1_2(old);
    TaVolume now(from), then(old);
    EXPECT_EQ(then.container().version_minor(), 2u);
    for (int l = 0; l < now.geometry().level_count(); ++l) {
      const Box box = Box::whole(now.geometry().level(l).dims);
      const Volume a = now.decode_box(l, box, now.rank()), b = then.decode_box(l, box, then.rank());
      EXPECT_EQ(max_abs_diff(a, b).value, 0.0) << from << " level " << l;
    }
  }
}

// Truncated files of both modes at many lengths: a FormatError naming the file, nothing else.
TEST_F(TaForgedFiles, TruncatedFilesAreFormatErrors) {
  for (const fs::path& from : {good(), good_coded()}) {
    const auto bytes = forge::file_bytes(from);
    const fs::path p = *dir_ / "truncated.strata";
    for (std::size_t size = 0; size < bytes.size(); size += 1 + size / 16) {
      forge::write_file(p, std::span(bytes).first(size));
      const std::string msg = open_and_decode(p);
      EXPECT_TRUE(contains(msg, "truncated.strata: ")) << size << ": " << msg;
      EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ")) << size << ": " << msg;
    }
  }
}

// ta-global files (docs/format.md, "Codec ta-global") forged with every checksum valid: the
// global metadata, the bases and the feature-scale table are checked before any brick decodes,
// and every failure names the file and the field or section.
TEST_F(TaForgedFiles, GlobalBasesAndTheFeatureScaleTableAreChecked) {
  CompressParams g = params(16, 2, 8, "u16,b8log+");
  g.codec_name = kGlobalCodecName;
  const fs::path good_global = *dir_ / "global.strata";
  compress(prisms({30, 30, 30}, 4), good_global, g);
  EXPECT_EQ(open_and_decode(good_global), "");
  using Sections = std::vector<forge::Section>;
  auto section = [](Sections& all, const std::string& name) -> std::vector<std::byte>& {
    for (forge::Section& s : all)
      if (s.name == name) return s.bytes;
    throw std::runtime_error("no section " + name);
  };
  auto set_float = [](std::vector<std::byte>& bytes, std::size_t i, float v) {
    std::memcpy(bytes.data() + i * sizeof(float), &v, sizeof v);
  };
  struct Case {
    std::string expect;
    std::function<void(nlohmann::json&)> edit;
    std::function<void(Sections&)> sections;
  };
  const std::vector<Case> cases{
      {"metadata.global: missing", [](nlohmann::json& m) { m.erase("global"); }, nullptr},
      {"metadata.global.ranks: expected an array of 3 integers in [1, 16]",
       [](nlohmann::json& m) { m["global"]["ranks"] = {8, 8, 17}; }, nullptr},
      {"section global_bases: ", [](nlohmann::json& m) { m["global"]["ranks"] = {9, 8, 8}; }, nullptr},
      {"metadata.global.ladder[1]: ranks must increase", [](nlohmann::json& m) { m["global"]["ladder"] = {4, 4, 6, 8}; },
       nullptr},
      {"metadata.global.ladder[3]: expected an integer in [1, 8]", [](nlohmann::json& m) { m["global"]["ladder"] = {2, 4, 6, 9}; },
       nullptr},
      {"metadata.global.ladder: expected 1 to 16 ranks", [](nlohmann::json& m) { m["global"]["ladder"] = nlohmann::json::array(); },
       nullptr},
      {"section feature_scale: ", [](nlohmann::json& m) { m["global"]["ladder"] = {4, 8}; }, nullptr},
      {"no section named 'global_bases'", nullptr, [](Sections& s) { std::erase_if(s, [](auto& x) { return x.name == "global_bases"; }); }},
      {"section global_bases: ", nullptr, [&](Sections& s) { section(s, "global_bases").resize(section(s, "global_bases").size() - 4); }},
      {"holds a non-finite value", nullptr, [&](Sections& s) { set_float(section(s, "global_bases"), 7, std::nanf("")); }},
      {"section feature_scale: ", nullptr, [&](Sections& s) { section(s, "feature_scale").resize(12); }},
      {"section feature_scale: holds -1", nullptr, [&](Sections& s) { set_float(section(s, "feature_scale"), 2, -1.0f); }},
      {"section feature_scale: row 0 grows from rank 6 to rank 8", nullptr,
       [&](Sections& s) { set_float(section(s, "feature_scale"), 3, 1e6f); }},
  };
  int i = 0;
  for (const Case& c : cases) {
    const std::string name = "global" + std::to_string(i++) + ".strata";
    forge::rewrite(good_global, *dir_ / name, c.edit, nullptr, c.sections);
    const std::string msg = open_and_decode(*dir_ / name);
    EXPECT_TRUE(contains(msg, name + ": ")) << c.expect << "\n" << msg;
    EXPECT_TRUE(contains(msg, c.expect)) << c.expect << "\n" << msg;
    EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ") || contains(msg, "json.exception")) << msg;
  }
}
