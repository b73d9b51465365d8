// Tables of segment names: the formats atlases and proofreading tools write, and their errors.
#include <gtest/gtest.h>

#include <fstream>

#include "strata/core/error.hpp"
#include "strata/mixture/label_names.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::mixture;

namespace {

LabelNames load(const test::TempDir& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir / name, std::ios::binary) << text;
  return load_label_names(dir / name);
}

std::string error_of(const test::TempDir& dir, const std::string& name, const std::string& text) {
  try {
    load(dir, name, text);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(MixtureLabelNames, ReadsTextCsvAndJsonTables) {
  test::TempDir dir;
  // MRIcron's .nii.txt (space), an ITK-SNAP-like tab table with CRLF, comments and blanks.
  EXPECT_EQ(load(dir, "a.nii.txt", "1 Precentral_L 2001\n2 Precentral_R 2002\n"),
            (LabelNames{{1, "Precentral_L"}, {2, "Precentral_R"}}));
  EXPECT_EQ(load(dir, "b.txt", "# comment\r\n\r\n-3\tNegative\t0 0 0\r\n"), (LabelNames{{-3, "Negative"}}));
  EXPECT_EQ(load(dir, "c.csv", "id,name,extra\n7,\"Frontal, \"\"sup\"\"\",x\n8,Insula\n"),
            (LabelNames{{7, "Frontal, \"sup\""}, {8, "Insula"}}));
  EXPECT_EQ(load(dir, "d.json", R"({"40": "cell", "-1": "outside"})"), (LabelNames{{-1, "outside"}, {40, "cell"}}));
}

TEST(MixtureLabelNames, ErrorsNameTheFileAndTheLine) {
  test::TempDir dir;
  EXPECT_NE(error_of(dir, "e.txt", "1 a\nx b\n").find("e.txt: line 2: expected a label value"), std::string::npos);
  EXPECT_NE(error_of(dir, "f.txt", "1 a\n1 b\n").find("f.txt: line 2: label 1 is named twice"), std::string::npos);
  EXPECT_NE(error_of(dir, "g.txt", "5\n").find("g.txt: line 1: label 5 has no name"), std::string::npos);
  EXPECT_NE(error_of(dir, "h.csv", "1,a\nlabel,name\n").find("h.csv: line 2"), std::string::npos);  // a header only first
  EXPECT_NE(error_of(dir, "i.json", R"({"x": "a"})").find("i.json: key \"x\""), std::string::npos);
  EXPECT_NE(error_of(dir, "j.json", "[1]").find("j.json: expected a JSON object"), std::string::npos);
  EXPECT_NE(error_of(dir, "k.txt", "1 " + std::string(kMaxLabelNameBytes + 1, 'n') + "\n").find("bytes long"),
            std::string::npos);
  EXPECT_THROW(load_label_names(dir / "missing.txt"), Error);
}

TEST(MixtureLabelNames, MetadataRoundTripAndForgedEntries) {
  const LabelNames names{{1, "a"}, {-2, "b"}};
  EXPECT_EQ(label_names_from_json(label_names_json(names), "f.strata"), names);
  EXPECT_THROW(label_names_from_json(nlohmann::json::array(), "f.strata"), FormatError);
  EXPECT_THROW(label_names_from_json({{"01", "a"}}, "f.strata"), FormatError);  // not canonical
  EXPECT_THROW(label_names_from_json({{"1", ""}}, "f.strata"), FormatError);
  EXPECT_THROW(label_names_from_json({{"1", 3}}, "f.strata"), FormatError);
}

TEST(MixtureLabelNames, SidecarIsTheMricronTextBesideTheVolume) {
  test::TempDir dir;
  std::ofstream(dir / "aal.nii.txt") << "1 a\n";
  EXPECT_EQ(sidecar_label_names(dir / "aal.nii.gz"), dir / "aal.nii.txt");
  EXPECT_EQ(sidecar_label_names(dir / "aal.nii"), dir / "aal.nii.txt");
  EXPECT_FALSE(sidecar_label_names(dir / "other.nii.gz"));
}
