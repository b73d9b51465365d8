// Forged Mixture Graph label files whose container checksums are valid: metadata, label map and
// sections that contradict each other are FormatErrors naming the file and the field, never a
// silent decode with wrong values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "store/forge.hpp"
#include "support/test_support.hpp"

namespace strata::mixture {
namespace {

namespace fs = std::filesystem;
namespace forge = strata::test::forge;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// What opening and decoding levels 0 and 1 throws (forge::failure_of).
std::string open_and_decode(const fs::path& p) {
  return forge::failure_of([&] {
    EncodedLabels e(p);
    e.decode_level0();
    e.dominant_labels(1);
  });
}

// 24x20x16 Voronoi labels as u32, encoded with each id layout.
class MixtureForgedFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    gen::Params p;
    p.kind = gen::Kind::voronoi;
    p.dims = {24, 20, 16};
    p.count = 12;
    const Volume v = gen::generate(p).converted(DType::u32);
    EncodeOptions blocks;
    encode_labels(v, good(), blocks);
    EncodeOptions fixed;
    fixed.ids = IdsMode::fixed;
    encode_labels(v, *dir_ / "fixed.strata", fixed);
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path good() { return *dir_ / "good.strata"; }

  static fs::path rewritten(const std::string& name, const std::function<void(nlohmann::json&)>& edit,
                            const std::function<void(std::vector<forge::Section>&)>& sections = nullptr) {
    const fs::path p = *dir_ / name;
    forge::rewrite(good(), p, edit, nullptr, sections);
    return p;
  }

  static inline test::TempDir* dir_ = nullptr;
};

// The label map section with one value replaced (kept increasing, checksums valid).
std::function<void(std::vector<forge::Section>&)> label_value(bool first, std::int64_t value) {
  return [=](std::vector<forge::Section>& sections) {
    for (auto& s : sections)
      if (s.name == "label_map") {
        const auto n = load_field<std::uint32_t>(s.bytes, 0);
        store_field(std::span(s.bytes), 4 + 8 * (first ? 0 : n - 1), value);
      }
  };
}

}  // namespace

// -5 in a u32 file decoded as 4294967291 and 2^40 as 0.
TEST_F(MixtureForgedFiles, LabelValuesMustFitTheSampleType) {
  ASSERT_EQ(open_and_decode(good()), "");
  std::string msg = open_and_decode(rewritten("negative.strata", nullptr, label_value(true, -5)));
  EXPECT_TRUE(contains(msg, "negative.strata: section label_map: label map: value -5 does not fit the sample type u32 (0..4294967295)"))
      << msg;
  msg = open_and_decode(rewritten("huge.strata", nullptr, label_value(false, std::int64_t(1) << 40)));
  EXPECT_TRUE(contains(msg, "huge.strata: section label_map: label map: value 1099511627776 does not fit the sample type u32"))
      << msg;
}

TEST_F(MixtureForgedFiles, MetadataIsCheckedAgainstItselfAndTheSections) {
  struct Case {
    std::string expect;
    std::function<void(nlohmann::json&)> edit;
  };
  const std::vector<Case> cases{
      {"metadata.mixture_graph_version: expected an integer in [1, 1], got 2", [](nlohmann::json& m) { m["mixture_graph_version"] = 2; }},
      {"metadata.source.spacing: expected an array of 3 finite numbers > 0, got array [0,1.0,1.0]", [](nlohmann::json& m) { m["source"]["spacing"][0] = 0; }},
      {"metadata.source.spacing: expected an array of 3 finite numbers > 0, got array [1.0,-2,1.0]", [](nlohmann::json& m) { m["source"]["spacing"][1] = -2; }},
      {"metadata.source.spacing: expected an array of 3 finite numbers > 0, got array [1.0,1.0,null]", [](nlohmann::json& m) { m["source"]["spacing"][2] = std::nan(""); }},
      {"metadata.source.dtype: a label volume has an integer sample type, got f32", [](nlohmann::json& m) { m["source"]["dtype"] = "f32"; }},
      {"metadata.source.dims: expected an array of 3 integers in [1, 2147483647], got array [24,20,\"16\"]",
       [](nlohmann::json& m) { m["source"]["dims"][2] = "16"; }},
      {"metadata.bits: expected an integer in [1, 16], got 40", [](nlohmann::json& m) { m["bits"] = 40; }},
      {"metadata.bins: \"uniform\" does not match the bitstream's bin layout \"symmetric\"", [](nlohmann::json& m) { m["bins"] = "uniform"; }},
      {"metadata.levels[1].ids_bytes: says 3 but section ids_L1 holds", [](nlohmann::json& m) { m["levels"][1]["ids_bytes"] = 3; }},
      {"metadata.levels[0].dims: expected [24,20,16]", [](nlohmann::json& m) { m["levels"][0]["dims"] = {24, 20, 15}; }},
      {"metadata.levels: missing", [](nlohmann::json& m) { m.erase("levels"); }},
      {"metadata.ids: expected a string, got number 2", [](nlohmann::json& m) { m["ids"] = 2; }},
      {"metadata.codec: expected \"mixture-graph\"", [](nlohmann::json& m) { m.erase("codec"); }},
  };
  int i = 0;
  for (const Case& c : cases) {
    const std::string name = "case" + std::to_string(i++) + ".strata";
    const std::string msg = open_and_decode(rewritten(name, c.edit));
    EXPECT_TRUE(contains(msg, name + ": " + c.expect)) << c.expect << "\n" << msg;
    EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ") || contains(msg, "json.exception")) << msg;
  }
}

// Two id sections swapped in metadata.sections: their checksums are bound to their names.
TEST_F(MixtureForgedFiles, SwappedSectionsAreRefused) {
  const fs::path p = *dir_ / "swapped.strata";
  fs::copy_file(good(), p, fs::copy_options::overwrite_existing);
  forge::edit_metadata_in_place(p, [](nlohmann::json& m) { std::swap(m["sections"]["ids_L1"], m["sections"]["ids_L2"]); });
  const std::string msg = open_and_decode(p);
  EXPECT_TRUE(contains(msg, "swapped.strata: section ids_L1: checksum mismatch")) << msg;
}

// A label file written with the 1.2 rule still decodes to the same labels.
TEST_F(MixtureForgedFiles, Format12FilesStillDecode) {
  for (const std::string name : {"good", "fixed"}) {
    const fs::path from = *dir_ / (name + ".strata"), old = *dir_ / (name + "-v12.strata");
    fs::copy_file(from, old, fs::copy_options::overwrite_existing);
    forge::downgrade_to_1_2(old);
    const Volume a = EncodedLabels(from).decode_level0(), b = EncodedLabels(old).decode_level0();
    ASSERT_EQ(a.byte_size(), b.byte_size());
    EXPECT_EQ(std::memcmp(a.bytes(), b.bytes(), a.byte_size()), 0) << name;
  }
}

TEST_F(MixtureForgedFiles, TruncatedFilesAreFormatErrors) {
  for (const std::string name : {"good", "fixed"}) {
    const auto bytes = forge::file_bytes(*dir_ / (name + ".strata"));
    const fs::path p = *dir_ / "truncated.strata";
    for (std::size_t size = 0; size < bytes.size(); size += 1 + size / 16) {
      forge::write_file(p, std::span(bytes).first(size));
      const std::string msg = open_and_decode(p);
      EXPECT_TRUE(contains(msg, "truncated.strata: ")) << size << ": " << msg;
      EXPECT_FALSE(contains(msg, "FOREIGN") || contains(msg, "Error: ")) << size << ": " << msg;
    }
  }
}

}  // namespace strata::mixture
