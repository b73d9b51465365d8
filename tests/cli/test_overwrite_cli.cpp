// Outputs that would overwrite what an input reads: the data file a detached NRRD header names,
// a raw file's JSON sidecar, the same file through a hard link or a symlink, a file inside an
// input folder (TIFF slices, a Zarr store) and a folder that holds an input. Every command
// refuses them before writing anything, with `error: <flag>:` naming both paths (exit 2), and
// the inputs stay as they were.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_test_util.hpp"
#include "support/test_support.hpp"

using strata::test::run_command;
using strata::test::shell_quoted;
using strata::test::strata_cmd;
using strata::test::TempDir;

namespace {

namespace fs = std::filesystem;

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Small inputs made once: a scalar NRRD, its .strata, a label .strata, a detached NRRD pair
// (hb.nhdr + hb.raw), a raw volume with its sidecar, a TIFF folder and an OME-Zarr store.
class OverwriteCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    std::string out;
    const auto ok = [&](const std::string& args) { ASSERT_EQ(run_command(strata_cmd(args), &out), 0) << args << "\n" << out; };
    ok("generate sphere --size 12 -o " + q("s.nrrd"));
    ok("compress " + q("s.nrrd") + " --brick 8 -o " + q("s.strata"));
    ok("generate voronoi --size 12 --count 4 -o " + q("v.nrrd"));
    ok("labels encode " + q("v.nrrd") + " -o " + q("v.strata"));
    ok("convert --uncompressed " + q("s.nrrd") + " " + q("hb.nhdr"));
    ok("convert " + q("s.nrrd") + " " + q("r.raw"));
    fs::create_directory(file("tiffs"));
    ok("convert " + q("s.nrrd") + " " + q("tiffs"));
    ok("convert " + q("s.nrrd") + " " + q("z.ome.zarr"));
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path file(const std::string& name) { return dir_->path() / name; }
  static std::string q(const std::string& name) { return shell_quoted(file(name)); }

  // Runs `args`; expects exit 2, `error: <flag>` and every one of `parts` in the output.
  static void refused(const std::string& args, const std::string& flag, const std::vector<std::string>& parts) {
    SCOPED_TRACE(args);
    std::string out;
    EXPECT_EQ(run_command(strata_cmd(args), &out), 2) << out;
    EXPECT_TRUE(has(out, "error: " + flag + ": ")) << out;
    for (const std::string& part : parts) EXPECT_TRUE(has(out, part)) << "\"" << part << "\" missing: " << out;
  }

  static TempDir* dir_;
};

TempDir* OverwriteCli::dir_ = nullptr;

TEST_F(OverwriteCli, ConvertRefusesTheDataFileOfADetachedHeader) {
  const std::string data = read_all(file("hb.raw"));
  // The case: `convert hb.nhdr hb.raw` exited 0 and rewrote hb.raw.
  refused("convert " + q("hb.nhdr") + " " + q("hb.raw"), "output",
          {file("hb.raw").string(), file("hb.nhdr").string(), "data file", "destroy the input"});
  // Through another spelling, a symlink and a hard link of the data file.
  fs::create_directories(file("sub"));
  refused("convert " + q("hb.nhdr") + " " + shell_quoted(file("sub") / ".." / "hb.raw"), "output", {"data file"});
  fs::create_symlink(file("hb.raw"), file("hb_link.raw"));
  refused("convert " + q("hb.nhdr") + " " + q("hb_link.raw"), "output", {"hb_link.raw", "data file"});
  fs::create_hard_link(file("hb.raw"), file("hb_hard.raw"));
  refused("convert " + q("hb.nhdr") + " " + q("hb_hard.raw"), "output", {"hb_hard.raw", "data file"});
  // The output's own data file would be the input: `r.nhdr` writes `r.raw`.
  refused("convert --uncompressed " + q("r.raw") + " " + q("r.nhdr"), "output",
          {"also writes its data file", file("r.raw").string(), "the input"});
  EXPECT_EQ(read_all(file("hb.raw")), data);
  for (const char* name : {"hb.raw.json", "r.nhdr", "hb.raw.tmp"}) EXPECT_FALSE(fs::exists(file(name))) << name;
}

TEST_F(OverwriteCli, OtherCommandsRefuseWhatTheirInputsRead) {
  const std::string sidecar = read_all(file("r.raw.json")), strata = read_all(file("s.strata"));
  // render --stats over the raw input's sidecar.
  refused("render " + q("r.raw") + " -o " + q("r.png") + " --size 16x16 --stats " + q("r.raw.json"), "--stats",
          {file("r.raw.json").string(), "JSON sidecar", file("r.raw").string()});
  // compress into the file a detached header names as its data.
  fs::copy_file(file("hb.raw"), file("d.strata"));
  std::string header = read_all(file("hb.nhdr"));
  header.replace(header.find("data file: hb.raw"), 17, "data file: d.strata");
  std::ofstream(file("d.nhdr"), std::ios::binary) << header;
  refused("compress " + q("d.nhdr") + " -o " + q("d.strata"), "--output", {"d.strata", "d.nhdr", "data file"});
  refused("labels encode " + q("d.nhdr") + " -o " + q("d.strata"), "--output", {"d.strata", "data file"});
  // decompress whose raw output's sidecar would be the input container.
  fs::copy_file(file("s.strata"), file("back.raw.json"));
  refused("decompress " + q("back.raw.json") + " -o " + q("back.raw"), "--output",
          {"also writes its JSON sidecar", file("back.raw.json").string()});
  // labels decode through a hard link of its input as the output's data file (gzip: .raw.gz).
  fs::create_hard_link(file("v.strata"), file("labels.raw.gz"));
  refused("labels decode " + q("v.strata") + " -o " + q("labels.nhdr"), "--output", {"labels.raw.gz", "v.strata"});
  EXPECT_EQ(read_all(file("r.raw.json")), sidecar);
  EXPECT_EQ(read_all(file("back.raw.json")), strata);
  for (const char* name : {"r.png", "back.raw", "labels.nhdr"}) EXPECT_FALSE(fs::exists(file(name))) << name;
}

TEST_F(OverwriteCli, InputFoldersAreNeitherOutputsNorHoldOutputs) {
  const auto slices = std::distance(fs::directory_iterator(file("tiffs")), fs::directory_iterator{});
  // A file inside the TIFF folder would become one of its slices (or stop it from reading).
  refused("convert " + q("tiffs") + " " + shell_quoted(file("tiffs") / "out.nrrd"), "output",
          {"lies inside the input '" + file("tiffs").string() + "'"});
  // The folder itself, and an OME-Zarr store as the output of its own conversion.
  refused("convert " + q("tiffs") + " " + q("tiffs"), "output", {"tiffs"});
  refused("convert " + q("z.ome.zarr") + " " + q("z.ome.zarr"), "output", {"z.ome.zarr"});
  refused("convert " + q("z.ome.zarr") + " " + shell_quoted(file("z.ome.zarr") / "0" / "x.nrrd"), "output",
          {"lies inside", "z.ome.zarr"});
  // A folder the output replaces whole that holds an input.
  fs::create_directories(file("outer"));
  fs::copy_file(file("s.nrrd"), file("outer") / "in.nrrd");
  refused("convert " + shell_quoted(file("outer") / "in.nrrd") + " " + q("outer"), "output",
          {"replaces whole", file("outer").string()});
  EXPECT_EQ(std::distance(fs::directory_iterator(file("tiffs")), fs::directory_iterator{}), slices);
  EXPECT_TRUE(fs::exists(file("outer") / "in.nrrd"));
}

TEST_F(OverwriteCli, RenderFramesSpareTheInput) {
  // An orbit's folder may hold the input, but no frame may be it.
  fs::create_directories(file("frames"));
  fs::copy_file(file("s.strata"), file("frames") / "frame_0001.png");
  refused("render " + shell_quoted(file("frames") / "frame_0001.png") + " --orbit 3 --size 16x16 -o " + q("frames"),
          "--output", {"frame_0001.png", "destroy the input"});
  EXPECT_EQ(read_all(file("frames") / "frame_0001.png"), read_all(file("s.strata")));
  EXPECT_FALSE(fs::exists(file("frames") / "frame_0000.png"));
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("render " + shell_quoted(file("frames") / "frame_0001.png") +
                                   " --orbit 1 --size 16x16 -o " + q("frames")),
                        &out),
            0)
      << out;
  EXPECT_TRUE(fs::exists(file("frames") / "frame_0000.png"));
}

}  // namespace
