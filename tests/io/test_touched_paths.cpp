// What reading and writing a volume path touches (io::files_read, io::files_written) and the one
// check that an output spares every input (io::overwrite_conflict): by identity of the file, so
// another spelling, a symlink or a hard link is caught, and by folders, so an output inside an
// input folder, or an input inside a folder the writer replaces whole, is refused too.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "io/dicom_data.hpp"
#include "io/io_test_util.hpp"
#include "strata/io/convert.hpp"
#include "strata/io/touched_paths.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using namespace strata::test::io;

// The touched path equal to `path` (lexically), or null.
const TouchedPath* find(const std::vector<TouchedPath>& all, const fs::path& path) {
  const auto it = std::find_if(all.begin(), all.end(),
                               [&](const TouchedPath& t) { return t.path.lexically_normal() == path.lexically_normal(); });
  return it == all.end() ? nullptr : &*it;
}

std::string conflict_of(const std::vector<TouchedPath>& outputs, const std::vector<TouchedPath>& inputs) {
  return overwrite_conflict(outputs, inputs).value_or("");
}

TEST(IoTouchedPaths, ADetachedHeaderReadsItsDataFilesOneListOrPattern) {
  test::TempDir dir;
  write_volume(dir / "v.nhdr", Volume(Extent{2, 2, 2}, DType::u8), with_compression(false));
  const auto read = files_read(dir / "v.nhdr");
  ASSERT_NE(find(read, dir / "v.nhdr"), nullptr);
  const TouchedPath* data = find(read, dir / "v.raw");
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(data->role, "data file");
  EXPECT_EQ(data->field, "data file");
  EXPECT_EQ(data->named, dir / "v.nhdr");

  // LIST: the names on the lines after it; a pattern: its range (the reader refuses both, but
  // no output may overwrite them either).
  write_text(dir / "list.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                                "data file: LIST 2\na.raw\nsub/b.raw\n");
  const auto listed = files_read(dir / "list.nhdr");
  EXPECT_NE(find(listed, dir / "a.raw"), nullptr);
  EXPECT_NE(find(listed, dir / "sub" / "b.raw"), nullptr);
  write_text(dir / "pattern.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 3\nencoding: raw\n"
                                   "data file: slice%03d.raw 1 5 2 2\n");
  const auto pattern = files_read(dir / "pattern.nhdr");
  for (const char* name : {"slice001.raw", "slice003.raw", "slice005.raw"}) EXPECT_NE(find(pattern, dir / name), nullptr) << name;
  EXPECT_EQ(find(pattern, dir / "slice002.raw"), nullptr);
  // An absolute data file stays absolute; an attached header reads only itself.
  write_text(dir / "abs.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\ndata file: " +
                                   (dir / "elsewhere.raw").string() + "\n");
  EXPECT_NE(find(files_read(dir / "abs.nhdr"), dir / "elsewhere.raw"), nullptr);
  write_volume(dir / "attached.nrrd", Volume(Extent{2, 2, 2}, DType::u8));
  EXPECT_EQ(files_read(dir / "attached.nrrd").size(), 1u);
}

TEST(IoTouchedPaths, ARawFileReadsItsSidecar) {
  test::TempDir dir;
  write_volume(dir / "r.raw", Volume(Extent{2, 2, 2}, DType::u8));
  const TouchedPath* sidecar = find(files_read(dir / "r.raw"), dir / "r.raw.json");
  ASSERT_NE(sidecar, nullptr);
  EXPECT_EQ(sidecar->role, "JSON sidecar");
  // The stem form <name>.json.
  fs::rename(dir / "r.raw.json", dir / "r.json");
  EXPECT_NE(find(files_read(dir / "r.raw"), dir / "r.json"), nullptr);
  // Not volumes: only themselves.
  write_text(dir / "colors.json", "{}");
  EXPECT_EQ(files_read(dir / "colors.json").size(), 1u);
  EXPECT_EQ(files_read(dir / "missing.nhdr").size(), 1u);
}

TEST(IoTouchedPaths, WritersNameTheirDataFilesSidecarsTemporariesAndFolders) {
  test::TempDir dir;
  WriteOptions raw_data;
  raw_data.compress = false;
  const auto nhdr = files_written(dir / "o.nhdr", raw_data);
  for (const char* name : {"o.nhdr", "o.nhdr.tmp", "o.raw", "o.raw.tmp"}) EXPECT_NE(find(nhdr, dir / name), nullptr) << name;
  EXPECT_EQ(find(nhdr, dir / "o.raw")->role, "data file");
  EXPECT_NE(find(files_written(dir / "o.nhdr", {}), dir / "o.raw.gz"), nullptr);
  const auto raw = files_written(dir / "o.raw", {});
  for (const char* name : {"o.raw", "o.raw.json", "o.raw.json.tmp"}) EXPECT_NE(find(raw, dir / name), nullptr) << name;
  const auto tiff_folder = files_written(dir / "slices", WriteOptions{.format = "tiff"});
  ASSERT_NE(find(tiff_folder, dir / "slices"), nullptr);
  EXPECT_TRUE(find(tiff_folder, dir / "slices")->replaced_folder);
  EXPECT_TRUE(find(tiff_folder, dir / "slices.tmp")->replaced_folder);
  EXPECT_FALSE(find(files_written(dir / "stack.tif", {}), dir / "stack.tif")->replaced_folder);
  EXPECT_TRUE(find(files_written(dir / "o.ome.zarr", {}), dir / "o.ome.zarr")->replaced_folder);
  EXPECT_NE(find(files_written(dir / "o.h5:/group/name", {}), dir / "o.h5"), nullptr);
  EXPECT_NE(find(plain_file_written(dir / "o.strata"), dir / "o.strata.tmp"), nullptr);
}

TEST(IoTouchedPaths, TheSameFileByAnyPathConflicts) {
  test::TempDir dir;
  write_text(dir / "in.raw", "x");
  fs::create_symlink(dir / "in.raw", dir / "link.raw");
  fs::create_hard_link(dir / "in.raw", dir / "hard.raw");
  fs::create_directories(dir / "sub");
  const std::vector<TouchedPath> inputs{touched_itself(dir / "in.raw")};
  for (const fs::path& out : {dir / "in.raw", dir / "link.raw", dir / "hard.raw", dir / "sub" / ".." / "in.raw",
                              dir / "." / "in.raw"}) {
    SCOPED_TRACE(out.string());
    const std::string why = conflict_of({touched_itself(out)}, inputs);
    EXPECT_NE(why.find(out.string()), std::string::npos) << why;
    EXPECT_NE(why.find("the input '" + (dir / "in.raw").string() + "'"), std::string::npos) << why;
    EXPECT_NE(why.find("destroy the input"), std::string::npos) << why;
  }
  EXPECT_EQ(conflict_of({touched_itself(dir / "other.raw")}, inputs), "");
}

// Slice `k` of a tiny DICOM series (2x2, 16-bit).
void write_dicom_slice(const fs::path& path, int k) {
  test::io::DicomData d;
  d.text(0x0020, 0x000E, "UI", "1.2.3")
      .text(0x0020, 0x0032, "DS", "0\\0\\" + std::to_string(k))
      .text(0x0020, 0x0037, "DS", "1\\0\\0\\0\\1\\0")
      .us(0x0028, 0x0002, 1)
      .text(0x0028, 0x0004, "CS", "MONOCHROME2")
      .us(0x0028, 0x0010, 2)
      .us(0x0028, 0x0011, 2)
      .text(0x0028, 0x0030, "DS", "1\\1")
      .us(0x0028, 0x0100, 16)
      .us(0x0028, 0x0101, 16)
      .us(0x0028, 0x0102, 15)
      .us(0x0028, 0x0103, 1)
      .pixels({std::int16_t(k), 1, 2, 3});
  d.write(path);
}

TEST(IoTouchedPaths, OutputsInsideAnInputFolderAndInputsInsideAReplacedFolderConflict) {
  test::TempDir dir;
  fs::create_directories(dir / "series");
  for (int k = 0; k < 3; ++k) write_dicom_slice(dir / "series" / ("IM" + std::to_string(k) + ".dcm"), k);
  ASSERT_EQ(open_volume(dir / "series")->info().dims, (Extent{2, 2, 3}));
  const auto series = files_read(dir / "series");
  // A file written into the series' folder (or a sub-folder of it) would join the series.
  for (const fs::path& out : {dir / "series" / "out.nrrd", dir / "series" / "sub" / "out.nrrd"}) {
    const std::string why = conflict_of(files_written(out, {}), series);
    EXPECT_NE(why.find("lies inside the input '" + (dir / "series").string() + "'"), std::string::npos) << why;
  }
  // The folder itself as a TIFF folder output, or a Zarr output folder that holds the input.
  EXPECT_NE(conflict_of(files_written(dir / "series", {}), series), "");
  fs::create_directories(dir / "out.zarr");
  write_text(dir / "out.zarr" / "in.raw", "x");
  const std::string why = conflict_of(files_written(dir / "out.zarr", {}), files_read(dir / "out.zarr" / "in.raw"));
  EXPECT_NE(why.find("replaces whole"), std::string::npos) << why;
  // A folder files are only added to (render's frames) may hold inputs.
  EXPECT_EQ(conflict_of({touched_itself(dir / "out.zarr")}, files_read(dir / "out.zarr" / "in.raw")), "");
  // Beside the folder is fine.
  EXPECT_EQ(conflict_of(files_written(dir / "series.nrrd", {}), series), "");
}

TEST(IoTouchedPaths, ConvertVolumeRefusesWhatItsInputReadsAndWritesNothing) {
  test::TempDir dir;
  const Volume v = random_volume({4, 3, 2}, DType::u16, 5);
  write_volume(dir / "hb.nhdr", v, with_compression(false));
  const std::string before = read_text(dir / "hb.raw");
  // The header's data file as the output, by its name and through a hard link.
  fs::create_hard_link(dir / "hb.raw", dir / "hard.raw");
  for (const char* out : {"hb.raw", "hard.raw"}) {
    SCOPED_TRACE(out);
    expect_error([&] { convert_volume(dir / "hb.nhdr", dir / out, {}, {}, silent_progress()); },
                 {out, "hb.nhdr", "data file"});
  }
  EXPECT_EQ(read_text(dir / "hb.raw"), before);
  EXPECT_FALSE(fs::exists(dir / "hb.raw.json"));
  // The output's own data file would be the input: `in.nhdr` writes `in.raw`.
  write_volume(dir / "in.raw", v);
  WriteOptions raw_data;
  raw_data.compress = false;
  expect_error([&] { convert_volume(dir / "in.raw", dir / "in.nhdr", {}, raw_data, silent_progress()); },
               {"in.nhdr", "also writes its data file", "in.raw"});
  EXPECT_FALSE(fs::exists(dir / "in.nhdr"));
  // Into a DICOM series' folder.
  fs::create_directories(dir / "series");
  for (int k = 0; k < 2; ++k) write_dicom_slice(dir / "series" / ("IM" + std::to_string(k) + ".dcm"), k);
  expect_error([&] { convert_volume(dir / "series", dir / "series" / "out.nrrd", {}, {}, silent_progress()); },
               {"out.nrrd", "lies inside", "series"});
  EXPECT_EQ(file_count(dir / "series"), 2u);
}

}  // namespace
}  // namespace strata::io
