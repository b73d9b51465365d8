// Which files `strata serve` takes from its arguments: files as given, folders as the volume
// files directly inside them (what `strata demo` leaves in demo-out/ included).
#include <gtest/gtest.h>

#include <fstream>

#include "strata/core/error.hpp"
#include "server/server_test_util.hpp"
#include "strata/server/api.hpp"
#include "support/test_support.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;

void touch(const fs::path& p) { std::ofstream(p) << "x"; }

TEST(ServerDatasetFiles, FoldersGiveTheirVolumeFilesSortedByName) {
  test::TempDir dir;
  for (const char* name : {"prisms.nrrd", "ch2better.strata", "aal.strata", "cells.tif", "prisms.nii.gz", "report.json",
                           "aal.png", "ch2better_rank16.png", "notes.txt", ".hidden.strata", "head.nhdr",
                           "vol.raw", "vol.raw.json", "orphan.raw", "other.raw", "other.json", "stack.tiff", "t1.nii"})
    touch(dir / name);
  fs::create_directory(dir / "sub.strata");  // folders inside are not volumes
  touch(dir / "sub.strata" / "inner.strata");
  const std::vector<DatasetFile> files = dataset_files({dir.path().string()});
  std::vector<std::string> names;
  for (const DatasetFile& f : files) {
    names.push_back(f.path.filename().string());
    EXPECT_EQ(f.folder, dir.path()) << "found in the folder";
  }
  EXPECT_EQ(names, (std::vector<std::string>{"aal.strata", "cells.tif", "ch2better.strata", "head.nhdr", "other.raw",
                                             "prisms.nii.gz", "prisms.nrrd", "stack.tiff", "t1.nii", "vol.raw"}));
}

TEST(ServerDatasetFiles, ArgumentsKeepTheirOrder) {
  test::TempDir dir;
  touch(dir / "b.strata");
  touch(dir / "a.strata");
  fs::create_directory(dir / "more");
  touch(dir / "more" / "c.nrrd");
  const auto files = dataset_files({(dir / "b.strata").string(), (dir / "more").string(), (dir / "a.strata").string()});
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(files[0].path.filename(), "b.strata");
  EXPECT_EQ(files[1].path.filename(), "c.nrrd");
  EXPECT_EQ(files[2].path.filename(), "a.strata");
  EXPECT_TRUE(files[0].folder.empty()) << "named itself";
  EXPECT_EQ(files[1].folder, dir / "more");
}

TEST(ServerDatasetFiles, MissingArgumentsAndEmptyFoldersAreErrors) {
  test::TempDir dir;
  EXPECT_NE(test::error_of([&] { dataset_files({(dir / "nope.strata").string()}); }).find("nope.strata"), std::string::npos);
  touch(dir / "readme.txt");
  EXPECT_NE(test::error_of([&] { dataset_files({dir.path().string()}); }).find("no volume files"), std::string::npos);
  EXPECT_EQ(test::parameter_of([] { Api api(std::vector<fs::path>{}); }), "files");
  EXPECT_EQ(test::parameter_of([] { Api api(std::vector<DatasetFile>{}); }), "files");
}

// A file found in a folder that does not open is left out, and the caller hears which and why;
// a file named itself still stops the server, as does a folder of which nothing opens.
TEST(ServerDatasetFiles, FilesOfAFolderThatDoNotOpenAreSkipped) {
  test::TempDir dir;
  fs::copy_file(testing::ServerData::get().files()[testing::kPlain], dir / "good.nrrd");
  std::ofstream(dir / "garbled.nrrd") << "NRRD0004\ntype: quaternion\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n12345678";
  std::vector<std::pair<fs::path, std::string>> skipped;
  ApiOptions options;
  options.on_skip = [&](const fs::path& file, const std::string& reason) { skipped.emplace_back(file, reason); };
  const Api api(dataset_files({dir.path().string()}), options);
  ASSERT_EQ(api.dataset_count(), 1u);
  EXPECT_NE(api.summary()[0].find("good"), std::string::npos);
  ASSERT_EQ(skipped.size(), 1u);
  EXPECT_EQ(skipped[0].first, dir / "garbled.nrrd");
  EXPECT_NE(skipped[0].second.find("quaternion"), std::string::npos) << "the reason: " << skipped[0].second;
  EXPECT_EQ(skipped[0].second.find(skipped[0].first.string()), std::string::npos) << "the file is not named twice";

  const std::string named = test::error_of([&] { Api a(dataset_files({(dir / "garbled.nrrd").string()}), options); });
  EXPECT_NE(named.find("garbled.nrrd"), std::string::npos) << named;
  fs::remove(dir / "good.nrrd");
  const std::string nothing = test::error_of([&] { Api a(dataset_files({dir.path().string()}), options); });
  EXPECT_EQ(nothing, "nothing to serve: no volume file in " + dir.path().string() + " opens");
}

}  // namespace
}  // namespace strata::server
