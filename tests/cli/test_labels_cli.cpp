// `strata labels encode | decode | palette` and `strata info` on a label file: round trips,
// JSON outputs and exit codes.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "support/test_support.hpp"

using strata::test::run_command;
using strata::test::TempDir;

namespace {

std::string strata_cmd(const std::string& args) { return std::string(STRATA_BINARY) + " --progress none " + args; }

}  // namespace

TEST(CliLabels, EncodeDecodeRoundTripBothIdModes) {
  TempDir dir;
  const std::string in = (dir / "v.nrrd").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 40,36,28 --count 30 -o " + in), &out), 0) << out;
  for (const std::string ids : {"blocks", "fixed"}) {
    const std::string enc = (dir / ("v-" + ids + ".strata")).string();
    ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc + " --ids " + ids + " --bits 8 --tau 2"), &out), 0) << out;
    EXPECT_NE(out.find("nodes"), std::string::npos) << out;
    EXPECT_NE(out.find("bits/voxel"), std::string::npos) << out;
    EXPECT_NE(out.find("max l1 error"), std::string::npos) << out;

    const std::string l0 = (dir / ("l0-" + ids + ".nrrd")).string();
    ASSERT_EQ(run_command(strata_cmd("labels decode " + enc + " --level 0 -o " + l0), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("compare --json " + in + " " + l0), &out), 0) << out;
    const auto m = nlohmann::json::parse(out);
    EXPECT_EQ(m["max_abs_error"], 0.0);

    ASSERT_EQ(run_command(strata_cmd("info --json " + enc), &out), 0) << out;
    const auto info = nlohmann::json::parse(out);
    EXPECT_EQ(info["codec"], "mixture-graph");
    EXPECT_GT(info["mixture_graph"]["nodes"].get<int>(), 30);
    EXPECT_EQ(info["mixture_graph"]["ids"], ids);
    EXPECT_EQ(info["mixture_graph"]["bits"], 8);
    ASSERT_EQ(run_command(strata_cmd("info " + enc), &out), 0) << out;
    EXPECT_NE(out.find("graph:"), std::string::npos) << out;
    EXPECT_NE(out.find("depth"), std::string::npos) << out;
  }
  const std::string enc = (dir / "v-blocks.strata").string();
  const std::string l2 = (dir / "l2.nrrd").string(), f2 = (dir / "f2.nrrd").string();
  ASSERT_EQ(run_command(strata_cmd("labels decode " + enc + " --level 2 -o " + l2), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("info --json " + l2), &out), 0) << out;
  EXPECT_EQ(nlohmann::json::parse(out)["dims"], nlohmann::json({10, 9, 7}));
  // Voronoi labels start at 1 (0 may be absent): take the first label of the decoded level.
  ASSERT_EQ(run_command(strata_cmd("labels decode " + enc + " --level 2 --label 1 -o " + f2), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("info --json " + f2), &out), 0) << out;
  const auto fi = nlohmann::json::parse(out);
  EXPECT_EQ(fi["dtype"], "f32");

  // Palette: RGBA per node.
  const std::string colors = (dir / "colors.json").string(), pal = (dir / "palette.json").string();
  std::ofstream(colors) << R"({"1": [1, 0, 0, 1], "2": [0, 1, 0, 0.5], "default": [0, 0, 1, 0.25]})";
  ASSERT_EQ(run_command(strata_cmd("labels palette " + enc + " --colors " + colors + " -o " + pal), &out), 0) << out;
  nlohmann::json p;
  std::ifstream(pal) >> p;
  ASSERT_TRUE(p.contains("rgba"));
  ASSERT_TRUE(p.contains("propagate_seconds"));
  EXPECT_EQ(p["rgba"].size(), p["nodes"].get<std::size_t>());
  for (const auto& c : p["rgba"]) {
    ASSERT_EQ(c.size(), 4u);
    const double sum = c[0].get<double>() + c[1].get<double>() + c[2].get<double>();
    EXPECT_NEAR(sum, 1.0, 1e-4);  // convex combinations of unit colours
  }
}

TEST(CliLabels, NamesTablesAreStoredForTheLabelsThatOccur) {
  // MRIcron's sidecar (<volume>.nii.txt beside <volume>.nii.gz) is read unless --names says
  // otherwise; a CSV with a header and a quoted comma, and a JSON object, read too; names of
  // labels the volume does not hold are left out.
  TempDir dir;
  const std::string in = (dir / "v.nii.gz").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 24 --count 5 -o " + in), &out), 0) << out;
  std::ofstream(dir / "v.nii.txt") << "# index name\n1 Precentral_L 2001\n2\tPrecentral_R\n999 Absent\n";
  std::ofstream(dir / "n.csv") << "label,name\n3,\"Frontal, superior\"\n";
  std::ofstream(dir / "n.json") << R"({"4": "Insula_L"})";
  const auto names_of = [&](const std::string& file) {
    EXPECT_EQ(run_command(strata_cmd("info --json " + file), &out), 0) << out;
    return nlohmann::json::parse(out)["mixture_graph"].value("label_names", 0);
  };
  const std::string sidecar = (dir / "a.strata").string();
  ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + sidecar), &out), 0) << out;
  EXPECT_NE(out.find("names: 2 segment names from"), std::string::npos) << out;
  EXPECT_EQ(names_of(sidecar), 2);
  for (const std::string table : {"n.csv", "n.json"}) {
    const std::string file = (dir / (table + ".strata")).string();
    ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + file + " --names " + (dir / table).string()), &out), 0) << out;
    EXPECT_EQ(names_of(file), 1) << table;
  }
  const std::string none = (dir / "none.strata").string();
  ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + none + " --names none"), &out), 0) << out;
  EXPECT_EQ(names_of(none), 0);
  std::ofstream(dir / "bad.txt") << "1 a\n1 b\n";
  EXPECT_NE(run_command(strata_cmd("labels encode " + in + " -o " + none + " --names " + (dir / "bad.txt").string()), &out), 0);
  EXPECT_NE(out.find("bad.txt: line 2: label 1 is named twice"), std::string::npos) << out;
}

TEST(CliLabels, ExitCodes) {
  TempDir dir;
  std::string out;
  const std::string in = (dir / "v.nrrd").string(), enc = (dir / "v.strata").string();
  ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 16 --count 8 -o " + in), &out), 0) << out;
  EXPECT_EQ(run_command(strata_cmd("labels"), &out), 2);
  EXPECT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc + " --ids sparse"), &out), 2);
  EXPECT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc + " --bits 0"), &out), 2);
  EXPECT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc + " --strategy best"), &out), 2);
  EXPECT_EQ(run_command(strata_cmd("labels encode " + in), &out), 2);  // -o missing
  EXPECT_EQ(run_command(strata_cmd("labels encode --help"), &out), 0);

  EXPECT_EQ(run_command(strata_cmd("labels encode '" + (dir / "missing.nrrd").string() + "' -o " + enc), &out), 1);
  EXPECT_NE(out.find("missing.nrrd"), std::string::npos) << out;
  // Float input is not a label volume.
  const std::string f = (dir / "f.nrrd").string();
  ASSERT_EQ(run_command(strata_cmd("generate marschner-lobb --size 8 -o " + f), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("info --json " + f), &out), 0) << out;
  ASSERT_EQ(nlohmann::json::parse(out)["dtype"], "f32");
  EXPECT_EQ(run_command(strata_cmd("labels encode " + f + " -o " + enc), &out), 1) << out;

  ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc), &out), 0) << out;
  EXPECT_EQ(run_command(strata_cmd("labels decode " + enc + " --level 9 -o x.nrrd"), &out), 1);
  EXPECT_NE(out.find("--level"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("labels decode " + enc + " --level 1 --label 99999 -o " + (dir / "x.nrrd").string()), &out), 1);
  EXPECT_NE(out.find("99999"), std::string::npos) << out;
  // A scalar .strata file or a corrupt one: exit 1 naming the file.
  const std::string bad = (dir / "bad.strata").string();
  std::ofstream(bad) << "not a strata file at all";
  EXPECT_EQ(run_command(strata_cmd("labels decode " + bad + " -o " + (dir / "x.nrrd").string()), &out), 1);
  EXPECT_NE(out.find("bad.strata"), std::string::npos) << out;
  std::ofstream(dir / "c.json") << "{\"1\": [1, 2]}";
  EXPECT_EQ(run_command(strata_cmd("labels palette " + enc + " --colors " + (dir / "c.json").string() + " -o " +
                                   (dir / "p.json").string()),
                        &out),
            1);
  EXPECT_NE(out.find("c.json"), std::string::npos) << out;
}

// `labels query`: the footprint answer sums to the box volume, agrees with the exact level-0
// scan (--naive, sigma 0) within a few sigma, and bad boxes are errors naming --box.
TEST(CliLabels, QueryAgreesWithTheExactScan) {
  strata::test::TempDir dir;
  const std::string in = (dir / "cells.nrrd").string(), enc = (dir / "cells.strata").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 48,40,36 --count 24 -o " + in), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc), &out), 0) << out;
  const std::string box = " --box 3,5,2:45,37,33 --json";
  ASSERT_EQ(run_command(strata_cmd("labels query " + enc + box), &out), 0) << out;
  const auto fast = nlohmann::json::parse(out);
  ASSERT_EQ(run_command(strata_cmd("labels query " + enc + box + " --naive"), &out), 0) << out;
  const auto exact = nlohmann::json::parse(out);
  const double volume = 42.0 * 32.0 * 31.0;
  double fast_total = 0, exact_total = 0;
  std::map<long long, std::pair<double, double>> fast_counts;
  for (const auto& l : fast["labels"]) {
    fast_total += l["count"].get<double>();
    fast_counts[l["label"].get<long long>()] = {l["count"].get<double>(), l["sigma"].get<double>()};
  }
  for (const auto& l : exact["labels"]) {
    exact_total += l["count"].get<double>();
    EXPECT_EQ(l["sigma"].get<double>(), 0.0);
    EXPECT_EQ(l["count"].get<double>(), std::round(l["count"].get<double>()));  // whole voxels
    const auto [count, sigma] = fast_counts[l["label"].get<long long>()];
    // Quantization error bound per label: the box volume times the graph's max l1 error.
    EXPECT_NEAR(count, l["count"].get<double>(), std::max(4 * sigma, volume * 0.006)) << l.dump();
  }
  EXPECT_NEAR(fast_total, volume, 1e-6 * volume);
  EXPECT_EQ(exact_total, volume);
  EXPECT_LT(fast["fetches"].get<double>(), exact["fetches"].get<double>());
  EXPECT_EQ(run_command(strata_cmd("labels query " + enc + " --box 0,0,0:99,10,10"), &out), 1) << out;
  EXPECT_NE(out.find("box"), std::string::npos) << out;

  // The coarse method: a bounded number of samples, counts still summing to the box volume.
  ASSERT_EQ(run_command(strata_cmd("labels query " + enc + box + " --method coarse --max-samples 8"), &out), 0) << out;
  const auto coarse = nlohmann::json::parse(out);
  EXPECT_EQ(coarse["method"], "coarse");
  EXPECT_LE(coarse["fetches"].get<double>(), 8.0);
  double coarse_total = 0;
  for (const auto& l : coarse["labels"]) coarse_total += l["count"].get<double>();
  EXPECT_NEAR(coarse_total, volume, 1e-6 * volume);
}

// `labels calibrate`: random boxes against exact counts; the JSON shares are consistent, the
// generated superpixel stack (real-like dyadic mixtures) stays within the 3-sigma acceptance,
// and bad arguments are usage errors.
TEST(CliLabels, CalibrateReportsSharesOutsideSigma) {
  TempDir dir;
  const std::string in = (dir / "sp.nrrd").string(), enc = (dir / "sp.strata").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate superpixels --size 64,60,40 --count 30 --seed 4 -o " + in), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("labels calibrate " + enc + " --sizes 8,24 --boxes 10 --json"), &out), 0) << out;
  const auto c = nlohmann::json::parse(out);
  EXPECT_EQ(c["boxes"], 20);
  EXPECT_GT(c["pairs"].get<int>(), 100);
  for (int k = 1; k < 6; ++k)
    EXPECT_GE(c["outside_" + std::to_string(k) + "_sigma"].get<double>(),
              c["outside_" + std::to_string(k + 1) + "_sigma"].get<double>());
  EXPECT_LE(c["outside_3_sigma"].get<double>(), 0.005);
  EXPECT_EQ(c["outside_6_sigma"].get<double>(), 0.0);
  ASSERT_EQ(run_command(strata_cmd("labels calibrate " + enc + " --boxes 3"), &out), 0) << out;
  EXPECT_NE(out.find("outside 1/2/3/6 sigma"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("labels calibrate " + enc + " --sizes 0"), &out), 2) << out;
  EXPECT_EQ(run_command(strata_cmd("labels calibrate " + enc + " --boxes 0"), &out), 2) << out;
  EXPECT_EQ(run_command(strata_cmd("labels calibrate " + enc + " --sizes nan"), &out), 2) << out;
  // A box edge beyond the volume is clamped to it, not an error or an overrun.
  ASSERT_EQ(run_command(strata_cmd("labels calibrate " + enc + " --sizes 1000000000 --boxes 2 --json"), &out), 0) << out;
  EXPECT_EQ(nlohmann::json::parse(out)["boxes"], 2);
  EXPECT_EQ(run_command(strata_cmd("labels calibrate " + enc + " --method naive"), &out), 2) << out;
  EXPECT_EQ(run_command(strata_cmd("labels calibrate " + (dir / "missing.strata").string()), &out), 1) << out;
}

// `labels encode --normals` adds the normals graph; `render --lighting normals` uses it, and
// refuses files without it by the flag's name.
TEST(CliLabels, NormalsGraphEncodesAndLightsFrames) {
  TempDir dir;
  const std::string in = (dir / "v.nrrd").string(), plain = (dir / "plain.strata").string(),
                    lit = (dir / "lit.strata").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 32,28,24 --count 12 -o " + in), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + lit + " --normals --no-error"), &out), 0) << out;
  EXPECT_NE(out.find("normals graph: "), std::string::npos) << out;
  ASSERT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + plain + " --no-error"), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("render " + lit + " --size 48x40 --lighting normals --stats " + (dir / "s.json").string() +
                                   " -o " + (dir / "lit.png").string()),
                        &out),
            0)
      << out;
  std::ifstream stats(dir / "s.json");
  const auto s = nlohmann::json::parse(stats);
  EXPECT_EQ(s["frames"][0]["render"]["lighting"], "normals") << s.dump();
  ASSERT_EQ(run_command(strata_cmd("render " + plain + " --size 48x40 --lighting normals -o " + (dir / "x.png").string()), &out), 2)
      << out;
  EXPECT_NE(out.find("--lighting: "), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("render " + lit + " --lighting shiny -o " + (dir / "y.png").string()), &out), 2) << out;
  ASSERT_EQ(run_command(strata_cmd("render " + plain + " --size 48x40 --lighting gradient-ao --stats " +
                                   (dir / "ao.json").string() + " -o " + (dir / "ao.png").string()),
                        &out),
            0)
      << out;
  std::ifstream ao(dir / "ao.json");
  EXPECT_EQ(nlohmann::json::parse(ao)["frames"][0]["render"]["lighting"], "gradient-ao");
  // Every normals option out of range is refused before any work (exit 2), naming the flag.
  for (const char* option : {"--normals-radius 9", "--normals-radius 0", "--normals-band 4", "--normals-band -1",
                             "--normals-diffusion 65", "--normals-dither maybe"}) {
    const std::string bad = option;
    EXPECT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + (dir / "z.strata").string() + " --normals " + bad), &out), 2)
        << bad << ": " << out;
    EXPECT_NE(out.find(bad.substr(0, bad.find(' '))), std::string::npos) << bad << ": " << out;
    EXPECT_FALSE(std::filesystem::exists(dir / "z.strata")) << bad;
  }
}
