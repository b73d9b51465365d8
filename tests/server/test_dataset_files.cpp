// Which files `strata serve` takes from its arguments: files as given, folders as the volume
// files directly inside them (what `strata demo` leaves in demo-out/ included).
#include <gtest/gtest.h>

#include <fstream>

#include "strata/core/error.hpp"
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
  const std::vector<fs::path> files = dataset_files({dir.path().string()});
  std::vector<std::string> names;
  for (const fs::path& f : files) names.push_back(f.filename().string());
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
  EXPECT_EQ(files[0].filename(), "b.strata");
  EXPECT_EQ(files[1].filename(), "c.nrrd");
  EXPECT_EQ(files[2].filename(), "a.strata");
}

TEST(ServerDatasetFiles, MissingArgumentsAndEmptyFoldersAreErrors) {
  test::TempDir dir;
  EXPECT_NE(test::error_of([&] { dataset_files({(dir / "nope.strata").string()}); }).find("nope.strata"), std::string::npos);
  touch(dir / "readme.txt");
  EXPECT_NE(test::error_of([&] { dataset_files({dir.path().string()}); }).find("no volume files"), std::string::npos);
  EXPECT_EQ(test::parameter_of([] { Api api({}); }), "files");
}

}  // namespace
}  // namespace strata::server
