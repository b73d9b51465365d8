// Damaged or inconsistent files and bad parameters fail with a strata::Error that names the
// file and the field or brick, never with garbage, a foreign exception or a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <unistd.h>

#include "strata/store/container.hpp"
#include "store/forge.hpp"
#include "ta/ta_test_util.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;
namespace fs = std::filesystem;

namespace {

// 30x30x30 prisms, brick 16, overlap 2, rank 8: 3x3x3 + 2x2x2 + 1 bricks.
class TaRobustness : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    compress(prisms({30, 30, 30}, 4), good(), params(16, 2, 8, "u16,b8log+"));
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path good() { return *dir_ / "good.strata"; }

  // Copies good() to `out` with the metadata changed by `edit` and the bricks filtered by `keep`.
  static fs::path rewrite(const std::string& name, const std::function<void(nlohmann::json&)>& edit,
                          const std::function<bool(const store::BrickEntry&)>& keep = nullptr) {
    const fs::path out = *dir_ / name;
    store::ContainerReader in(good());
    store::ContainerWriter w(out);
    for (const auto& e : in.bricks())
      if (!keep || keep(e)) {
        const io::SharedBytes payload = in.payload(e);
        w.add_brick(e, payload);
      }
    nlohmann::json m = in.metadata();
    m.erase("sections");
    edit(m);
    w.finish(m);
    return out;
  }

  // What opening and fully decoding level 0 throws (forge::failure_of).
  static std::string open_and_decode(const fs::path& p) {
    return test::forge::failure_of([&] {
      TaVolume t(p);
      t.decode_box(0, Box::whole(t.geometry().level(0).dims), t.rank());
    });
  }

  static inline test::TempDir* dir_ = nullptr;
};


}  // namespace

TEST_F(TaRobustness, TheUntouchedCopyDecodes) {
  EXPECT_EQ(open_and_decode(rewrite("copy.strata", [](nlohmann::json&) {})), "");
}

TEST_F(TaRobustness, CorruptPayloadByteNamesTheBrick) {
  const fs::path p = *dir_ / "corrupt.strata";
  fs::copy_file(good(), p);
  const store::BrickEntry e = *store::ContainerReader(p).find({0, 1, 2, 1});
  ASSERT_TRUE(is_tucker(e.kind));
  strata::test::flip_byte(p, e.offset + e.size / 2);
  TaVolume t(p);  // metadata and index are intact: opening works, the brick fails when read
  std::string msg = error_of([&] { t.decode_box(0, {{10, 20, 10}, {20, 30, 20}}, 8); });
  EXPECT_TRUE(contains(msg, "corrupt.strata")) << msg;
  EXPECT_TRUE(contains(msg, "level 0, 1,2,1")) << msg;
  // Boxes that do not touch the brick still decode.
  EXPECT_EQ(error_of([&] { t.decode_box(0, {{0, 0, 0}, {12, 12, 12}}, 8); }), "");
}

TEST_F(TaRobustness, MissingBrickIsAFormatErrorNamingIt) {
  const auto p = rewrite("missing.strata", [](nlohmann::json&) {},
                         [](const store::BrickEntry& e) { return !(e.key == store::BrickKey{0, 2, 0, 1}); });
  const std::string msg = open_and_decode(p);
  EXPECT_TRUE(contains(msg, "missing.strata")) << msg;
  EXPECT_TRUE(contains(msg, "index")) << msg;
  EXPECT_TRUE(contains(msg, "level 0, 2,0,1")) << msg;
  EXPECT_FALSE(contains(msg, "FOREIGN")) << msg;
}

TEST_F(TaRobustness, WrongCodecIsAFormatErrorNamingMetadataCodec) {
  for (const auto& [name, edit] : std::vector<std::pair<std::string, std::function<void(nlohmann::json&)>>>{
           {"codec_other.strata", [](nlohmann::json& m) { m["codec"] = "mixture-graph"; }},
           {"codec_missing.strata", [](nlohmann::json& m) { m.erase("codec"); }},
           {"codec_number.strata", [](nlohmann::json& m) { m["codec"] = 5; }}}) {
    const std::string msg = open_and_decode(rewrite(name, edit));
    EXPECT_TRUE(contains(msg, name)) << msg;
    EXPECT_TRUE(contains(msg, "metadata.codec")) << msg;
    EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ")) << "not a FormatError: " << msg;
  }
}

TEST_F(TaRobustness, MissingOrBadTopLevelFieldsAreFormatErrorsNamingTheField) {
  struct Case {
    std::string field;
    std::function<void(nlohmann::json&)> edit;
  };
  const std::vector<Case> cases{
      {"metadata.source", [](nlohmann::json& m) { m.erase("source"); }},
      {"metadata.brick", [](nlohmann::json& m) { m.erase("brick"); }},
      {"metadata.brick", [](nlohmann::json& m) { m["brick"] = 4; }},  // core 0 with overlap 2
      {"metadata.brick", [](nlohmann::json& m) { m["brick"] = "sixteen"; }},
      {"metadata.overlap", [](nlohmann::json& m) { m.erase("overlap"); }},
      {"metadata.rank", [](nlohmann::json& m) { m.erase("rank"); }},
      {"metadata.rank", [](nlohmann::json& m) { m["rank"] = 0; }},
      {"metadata.rank", [](nlohmann::json& m) { m["rank"] = 17; }},
      {"metadata.rank", [](nlohmann::json& m) { m["rank"] = "8"; }},
      {"metadata.quant", [](nlohmann::json& m) { m.erase("quant"); }},
      {"metadata.quant", [](nlohmann::json& m) { m["quant"] = "u16,b9log"; }},
      {"metadata.levels", [](nlohmann::json& m) { m.erase("levels"); }},
      {"metadata.levels", [](nlohmann::json& m) { m["levels"].erase(0); }},
      {"metadata.source.value_range", [](nlohmann::json& m) { m["source"]["value_range"] = {1.0}; }},
      {"metadata.source.spacing", [](nlohmann::json& m) { m["source"]["spacing"] = {1.0, 2.0}; }},
      {"metadata.source.dims", [](nlohmann::json& m) { m["source"]["dims"] = {30, 30}; }},
  };
  int i = 0;
  for (const Case& c : cases) {
    const std::string name = "field" + std::to_string(i++) + ".strata";
    const std::string msg = open_and_decode(rewrite(name, c.edit));
    EXPECT_TRUE(contains(msg, name)) << c.field << ": " << msg;
    EXPECT_TRUE(contains(msg, c.field + ":")) << c.field << ": " << msg;
    EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ")) << "not a FormatError: " << msg;
  }
}

// Nested source fields: missing or mistyped entries must still be FormatErrors that name the
// full path metadata.source.<field> (not a bare json exception, not "metadata.<field>").
TEST_F(TaRobustness, MissingOrMistypedSourceFieldsNameTheirFullPath) {
  struct Case {
    std::string field;
    std::function<void(nlohmann::json&)> edit;
  };
  const std::vector<Case> cases{
      {"metadata.source.dims", [](nlohmann::json& m) { m["source"].erase("dims"); }},
      {"metadata.source.dims", [](nlohmann::json& m) { m["source"]["dims"] = {"a", "b", "c"}; }},
      {"metadata.source.dtype", [](nlohmann::json& m) { m["source"].erase("dtype"); }},
      {"metadata.source.spacing", [](nlohmann::json& m) { m["source"].erase("spacing"); }},
      {"metadata.source.value_range", [](nlohmann::json& m) { m["source"].erase("value_range"); }},
  };
  int i = 0;
  for (const Case& c : cases) {
    const std::string name = "source" + std::to_string(i++) + ".strata";
    const std::string msg = open_and_decode(rewrite(name, c.edit));
    EXPECT_TRUE(contains(msg, name)) << c.field << ": " << msg;
    EXPECT_TRUE(contains(msg, c.field + ":")) << c.field << ": " << msg;
    EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ")) << "not a FormatError: " << msg;
  }
}

TEST_F(TaRobustness, UnknownSourceDtypeNamesTheField) {
  const std::string msg =
      open_and_decode(rewrite("dtype.strata", [](nlohmann::json& m) { m["source"]["dtype"] = "complex128"; }));
  EXPECT_TRUE(contains(msg, "dtype.strata")) << msg;
  EXPECT_TRUE(contains(msg, "metadata.source.dtype")) << msg;
  EXPECT_TRUE(contains(msg, "complex128")) << msg;
  EXPECT_FALSE(contains(msg, "FOREIGN")) << msg;
}

TEST_F(TaRobustness, MetadataThatDisagreesWithThePayloadsIsAnErrorNotGarbage) {
  // Same core (12) and level count, but 18-wide bricks: the 16^3 payloads must be refused.
  const std::string width = open_and_decode(rewrite("width.strata", [](nlohmann::json& m) {
    m["brick"] = 18;
    m["overlap"] = 3;
  }));
  EXPECT_TRUE(contains(width, "width.strata")) << width;
  EXPECT_TRUE(contains(width, "16")) << width;
  EXPECT_FALSE(contains(width, "FOREIGN")) << width;
  EXPECT_NE(width, "");
  // A different quantization scheme: the byte counts no longer match.
  const std::string scheme = open_and_decode(rewrite("scheme.strata", [](nlohmann::json& m) { m["quant"] = "f32"; }));
  EXPECT_TRUE(contains(scheme, "scheme.strata")) << scheme;
  EXPECT_FALSE(contains(scheme, "FOREIGN")) << scheme;
  EXPECT_NE(scheme, "");
}

TEST(TaCompressErrors, RankOutsideOneToBrickWidthIsRejectedBeforeWriting) {
  test::TempDir dir;
  const Volume v = prisms({20, 20, 20}, 1);
  for (int rank : {0, -3, 17}) {
    const auto run = [&] { compress(v, dir / "r.strata", params(16, 2, rank, "u16,b8log+")); };
    EXPECT_EQ(parameter_of(run), "CodecParams::rank");
    const std::string msg = error_of(run);
    EXPECT_TRUE(contains(msg, "CodecParams::rank: ")) << msg;
    EXPECT_TRUE(contains(msg, "16")) << msg;
    EXPECT_FALSE(contains(msg, "--")) << msg;
  }
  EXPECT_EQ(error_of([&] { compress(v, dir / "ok.strata", params(16, 2, 16, "u16,b8log+", 1)); }), "");
  EXPECT_FALSE(fs::exists(dir / "r.strata"));
  EXPECT_FALSE(fs::exists(dir / "r.strata.tmp"));
  const auto bad_layout = [&] { compress(v, dir / "l.strata", params(16, 8, 4, "u16,b8log+")); };
  EXPECT_EQ(parameter_of(bad_layout), "BrickLayout::overlap");
  const std::string layout = error_of(bad_layout);
  EXPECT_TRUE(contains(layout, "got 8")) << layout;
  EXPECT_FALSE(fs::exists(dir / "l.strata.tmp"));
}

TEST(TaCompressErrors, MissingOutputDirectoryIsAnErrorNamingTheFile) {
  test::TempDir dir;
  const Volume v = prisms({20, 20, 20}, 1);
  const std::string msg =
      error_of([&] { compress(v, dir / "no" / "such" / "dir.strata", params(16, 2, 8, "u16,b8log+", 1)); });
  EXPECT_TRUE(contains(msg, "dir.strata")) << msg;
}

namespace {

// A volume with one non-finite sample in the middle of a brick, written as f32 raw.
fs::path raw_with(const fs::path& dir, float bad) {
  Volume v = prisms({24, 20, 18}, 9).converted(DType::f32);
  v.set_value(11, 9, 9, bad);
  const fs::path p = dir / "bad.raw";
  io::write_volume(p, v);
  return p;
}

// Exit codes of the child processes below.
constexpr int kCleanError = 0, kForeignException = 3, kNoError = 4, kWrongMessage = 5, kLeftovers = 6;

// The scratch directory of a death test's child: named after the test process (the child's
// parent), so the parent can remove it even when the child dies without cleaning up.
fs::path death_dir(pid_t test_process) {
  return fs::temp_directory_path() / ("strata-ta-death-" + std::to_string(test_process));
}

// In the child: runs `body` in death_dir(parent) and returns its code. Used inside EXPECT_EXIT,
// so a crash (std::terminate from an exception escaping an OpenMP region) shows up as a failed
// expectation instead of killing the whole suite.
int in_death_dir(const std::function<int(const fs::path&)>& body) {
  const fs::path dir = death_dir(getppid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return body(dir);
}

// In the parent, after EXPECT_EXIT.
void remove_death_dir() { fs::remove_all(death_dir(getpid())); }

}  // namespace

// A NaN or infinite sample (once an error here) is kept exactly: the fixed-rank mode codes the
// brick's other voxels and restores it (tests/ta/test_non_finite.cpp covers every mode).
TEST(TaCompressNonFinite, NanAndInfiniteSamplesOfARawFileDecodeAsThemselves) {
  test::TempDir dir;
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity()}) {
    const fs::path raw = raw_with(dir.path(), bad), out = dir / "out.strata";
    auto source = io::open_volume(raw);
    compress_volume(*source, out, params(8, 1, 4, "u16,b8log+", 1), silent_progress());
    const TaVolume t(out);
    const float decoded = t.decode_box(0, Box{{11, 9, 9}, {12, 10, 10}}, t.rank()).samples<float>()[0];
    if (std::isnan(bad)) EXPECT_TRUE(std::isnan(decoded));
    else EXPECT_EQ(decoded, bad);
    EXPECT_TRUE(std::isfinite(t.decode_box(0, Box{{10, 9, 9}, {11, 10, 10}}, t.rank()).samples<float>()[0]));
  }
}

// A write failure while bricks are being encoded (disk full) must surface as an Error and
// remove the temporary, not terminate the process. `<out>.tmp` is made a link to /dev/full.
TEST(TaCompressErrorsDeathTest, WriteFailureDuringEncodingIsAnErrorAndLeavesNoOutput) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  EXPECT_EXIT(std::exit(in_death_dir([](const fs::path& dir) {
                const fs::path out = dir / "full.strata", tmp = dir / "full.strata.tmp";
                fs::create_symlink("/dev/full", tmp);
                try {
                  compress(prisms({48, 48, 48}, 3), out, params(16, 2, 8, "u16,b8log+", 1));
                } catch (const Error& e) {
                  if (!contains(e.what(), "full.strata")) return kWrongMessage;
                  return fs::exists(out) || fs::exists(fs::symlink_status(tmp)) ? kLeftovers : kCleanError;
                } catch (...) {
                  return kForeignException;
                }
                return kNoError;
              })),
              ::testing::ExitedWithCode(kCleanError), "");
  remove_death_dir();
}
