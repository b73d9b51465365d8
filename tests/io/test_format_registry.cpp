// The volume format registry (strata/io/formats.hpp): a toy format registered from this file
// alone is detected by extension and by content, read, written, converted to and from NRRD by
// the function `strata convert` runs, compressed like any other input and listed; duplicates and
// incomplete entries are refused; messages list the registered extensions; and every format
// extension is spelled once in the sources, in its registry entry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "io/io_test_util.hpp"
#include "strata/io/convert.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/formats.hpp"
#include "strata/ta/compress.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// ---------------------------------------------------------------------------------------------
// The toy format: "TOY1", dims x y z and a dtype code as little-endian int64s, then the samples.
// u8 and u16 only, one volume, no spacing: a format that can do less than the built-ins.

constexpr std::string_view kToyMagic = "TOY1";
constexpr std::size_t kToyHeaderBytes = 4 + 4 * 8;

// A toy file read whole: the format does not stream.
class ToySource final : public VolumeSource {
 public:
  ToySource(Volume volume, fs::path path) : volume_(std::move(volume)), path_(std::move(path)) {}
  const VolumeInfo& info() const override { return volume_.info(); }
  const fs::path& path() const override { return path_; }
  Volume read_box(const Box& box) override { return volume_.crop(box); }

 private:
  Volume volume_;
  fs::path path_;
};

std::unique_ptr<VolumeSource> open_toy(const fs::path& path, const ReadOptions&) {
  std::ifstream in(path, std::ios::binary);
  std::string header(kToyHeaderBytes, '\0');
  if (!in.read(header.data(), std::streamsize(header.size())) || !header.starts_with(kToyMagic))
    throw FormatError(path.string(), "magic", "not a toy file");
  std::int64_t fields[4];
  std::memcpy(fields, header.data() + kToyMagic.size(), sizeof(fields));
  Volume v({fields[0], fields[1], fields[2]}, DType(fields[3]));
  if (!in.read(reinterpret_cast<char*>(v.bytes()), std::streamsize(v.byte_size())))
    throw FormatError(path.string(), "samples", "truncated");
  return std::make_unique<ToySource>(std::move(v), path);
}

class ToyWriter final : public VolumeWriter {
 public:
  ToyWriter(const fs::path& path, const VolumeInfo& info) : out_(path) {
    const std::int64_t fields[4] = {info.dims.x, info.dims.y, info.dims.z, std::int64_t(info.dtype)};
    out_.write(kToyMagic.data(), kToyMagic.size());
    out_.write(fields, sizeof(fields));
  }
  void write_slab(const Volume& slab) override { out_.write(slab.bytes(), slab.byte_size()); }
  void finish() override { out_.commit(); }

 private:
  AtomicOutputFile out_;
};

VolumeFormat toy_format() {
  return {
      .name = "toy",
      .title = "Toy",
      .description = "a test format: a 36-byte header and the samples",
      .extensions = {".toy"},
      .magic_bytes = kToyMagic.size(),
      .sniff = [](std::span<const std::byte> head) {
        return head.size() == kToyMagic.size() && std::memcmp(head.data(), kToyMagic.data(), head.size()) == 0;
      },
      .open = open_toy,
      .create_writer = [](const fs::path& path, const VolumeInfo& info,
                          const WriteOptions&) -> std::unique_ptr<VolumeWriter> {
        return std::make_unique<ToyWriter>(path, info);
      },
      .read_dtypes = {DType::u8, DType::u16},
      .write_dtypes = {DType::u8, DType::u16},
  };
}

// Registers the toy format once per test program, whichever test runs first.
const VolumeFormat& toy() {
  static const VolumeFormat* registered = [] {
    register_format(toy_format());
    return find_format("toy");
  }();
  return *registered;
}

Volume toy_volume() {
  Volume v({7, 5, 4}, DType::u16, {1, 1, 1});
  auto s = v.samples<std::uint16_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::uint16_t(i * 37 % 1000);
  return v;
}

std::vector<std::string> names_of(const std::vector<const VolumeFormat*>& all) {
  std::vector<std::string> names;
  for (const VolumeFormat* f : all) names.push_back(f->name);
  return names;
}

// ---------------------------------------------------------------------------------------------

TEST(IoFormatRegistry, BuiltInsComeFirstAndTheToyIsListedAfterThem) {
  toy();
  const std::vector<std::string> names = names_of(formats());
  ASSERT_GE(names.size(), 5u);
  EXPECT_EQ(std::vector<std::string>(names.begin(), names.begin() + 4),
            (std::vector<std::string>{"raw", "nrrd", "nifti", "tiff"}));
  EXPECT_NE(std::find(names.begin() + 4, names.end(), "toy"), names.end());
  EXPECT_EQ(find_format("toy"), &toy());
  EXPECT_EQ(find_format("gif"), nullptr);
}

TEST(IoFormatRegistry, DetectsTheToyByExtensionAndByContent) {
  TempDir dir;
  EXPECT_EQ(&detect_format(dir / "a.toy"), &toy());
  EXPECT_EQ(&detect_format(dir / "A.TOY"), &toy());
  EXPECT_EQ(format_by_extension(dir / "b.toy"), &toy());
  write_volume(dir / "c.toy", toy_volume());
  fs::copy_file(dir / "c.toy", dir / "mystery.dat");
  EXPECT_EQ(&detect_format(dir / "mystery.dat"), &toy());
  EXPECT_EQ(format_by_extension(dir / "mystery.dat"), nullptr);  // the name alone says nothing
  EXPECT_EQ(read_volume(dir / "mystery.dat"), toy_volume());
}

TEST(IoFormatRegistry, ReadsAndWritesTheToyThroughTheCommonEntryPoints) {
  TempDir dir;
  toy();
  write_volume(dir / "v.toy", toy_volume());
  EXPECT_EQ(read_volume(dir / "v.toy"), toy_volume());
  // What the format cannot store is refused before anything is written, naming file and type.
  const std::string error = test::error_of([&] { write_volume(dir / "f.toy", Volume({2, 2, 2}, DType::f32)); });
  EXPECT_NE(error.find("f.toy"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot store f32"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(dir / "f.toy"));
  // The shared slab checks wrap the toy's writer too.
  auto writer = create_volume_writer(dir / "w.toy", toy_volume().info());
  EXPECT_THROW(writer->finish(), Error);
  // A format of one volume: asking for another is refused for it by open_volume.
  ReadOptions second;
  second.volume = 1;
  EXPECT_EQ(test::parameter_of([&] { open_volume(dir / "v.toy", second); }), "ReadOptions::volume");
}

TEST(IoFormatRegistry, ConvertsTheToyToNrrdAndBackAsTheCliDoes) {
  TempDir dir;
  toy();
  write_volume(dir / "a.toy", toy_volume());
  const VolumeInfo written = convert_volume(dir / "a.toy", dir / "b.nrrd", {}, {}, silent_progress());
  EXPECT_EQ(written.dims, toy_volume().dims());
  EXPECT_EQ(read_volume(dir / "b.nrrd"), toy_volume());
  convert_volume(dir / "b.nrrd", dir / "c.toy", {}, {}, silent_progress());
  EXPECT_EQ(test::io::read_bytes(dir / "c.toy"), test::io::read_bytes(dir / "a.toy"));
  // WriteOptions::format names a registered format for a name without its extension.
  WriteOptions as_toy;
  as_toy.format = "toy";
  convert_volume(dir / "b.nrrd", dir / "d.out", {}, as_toy, silent_progress());
  EXPECT_EQ(read_volume(dir / "d.out"), toy_volume());
  // Samples the target cannot store: an error naming the output, and no output.
  write_volume(dir / "f.nrrd", Volume({2, 2, 2}, DType::f32));
  const std::string error =
      test::error_of([&] { convert_volume(dir / "f.nrrd", dir / "f.toy", {}, {}, silent_progress()); });
  EXPECT_NE(error.find("f.toy"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(dir / "f.toy"));
}

TEST(IoFormatRegistry, CompressesAToyFileAsItCompressesTheSameNrrd) {
  TempDir dir;
  toy();
  Volume v({20, 18, 17}, DType::u16);
  auto s = v.samples<std::uint16_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::uint16_t((i % 20) * (i / 360) + 3 * (i / 20 % 18));
  write_volume(dir / "v.toy", v);
  write_volume(dir / "v.nrrd", v);
  ta::CompressParams params;
  params.layout.brick = 8;
  params.codec.rank = 4;
  const auto from_toy = ta::compress_volume(*open_volume(dir / "v.toy"), dir / "toy.strata", params, silent_progress());
  const auto from_nrrd =
      ta::compress_volume(*open_volume(dir / "v.nrrd"), dir / "nrrd.strata", params, silent_progress());
  EXPECT_EQ(from_toy.input_voxels, std::uint64_t(v.voxel_count()));
  EXPECT_EQ(from_toy.core_bytes, from_nrrd.core_bytes);
  EXPECT_EQ(from_toy.factor_bytes, from_nrrd.factor_bytes);
  EXPECT_EQ(from_toy.levels.size(), from_nrrd.levels.size());
}

TEST(IoFormatRegistry, RefusesDuplicatesAndIncompleteEntries) {
  toy();
  const std::size_t before = formats().size();
  VolumeFormat again = toy_format();
  again.extensions = {".toy2"};
  EXPECT_NE(test::error_of([&] { register_format(again); }).find("\"toy\" is registered already"), std::string::npos);
  VolumeFormat stealing = toy_format();
  stealing.name = "thief";
  stealing.extensions = {".thief", ".nii.gz"};
  const std::string error = test::error_of([&] { register_format(stealing); });
  EXPECT_NE(error.find(".nii.gz"), std::string::npos) << error;
  EXPECT_NE(error.find("\"nifti\""), std::string::npos) << error;

  const auto refused = [](VolumeFormat f) { return !test::error_of([&] { register_format(std::move(f)); }).empty(); };
  VolumeFormat f = toy_format();
  f.name = "";
  EXPECT_TRUE(refused(f));
  f = toy_format();
  f.name = "no-reader";
  f.extensions = {".noreader"};
  f.open = nullptr;
  EXPECT_TRUE(refused(f));
  f = toy_format();
  f.name = "shouting";
  f.extensions = {".LOUD"};
  EXPECT_TRUE(refused(f));
  f.extensions = {"nodot"};
  EXPECT_TRUE(refused(f));
  f.extensions = {};
  EXPECT_TRUE(refused(f));  // neither an extension nor a folder form
  f.extensions = {".quiet"};
  f.magic_bytes = 0;
  EXPECT_TRUE(refused(f));  // a sniffer without magic bytes
  f = toy_format();
  f.name = "no-types";
  f.extensions = {".notypes"};
  f.write_dtypes = {};
  EXPECT_TRUE(refused(f));  // a writer without the types it writes
  EXPECT_EQ(formats().size(), before);
}

TEST(IoFormatRegistry, UnknownExtensionsListEveryRegisteredOne) {
  TempDir dir;
  toy();
  const std::string error = test::error_of([&] { detect_format(dir / "volume.xyz"); });
  EXPECT_NE(error.find("volume.xyz"), std::string::npos) << error;
  for (const VolumeFormat* f : formats()) {
    for (const std::string& ext : f->extensions) EXPECT_NE(error.find(ext), std::string::npos) << ext << ": " << error;
    if (!f->directory.empty()) {
      EXPECT_NE(error.find(f->directory), std::string::npos) << error;
    }
  }
  EXPECT_EQ(error, fmt::format("{}: unknown volume format (expected {})", (dir / "volume.xyz").string(),
                               known_extensions_text()));
  // The same for writing, and a format name that is not registered names the parameter.
  EXPECT_NE(test::error_of([&] { create_volume_writer(dir / "out.xyz", toy_volume().info()); }).find(".toy"),
            std::string::npos);
  EXPECT_EQ(test::parameter_of([&] { output_format(dir / "out.xyz", "gif"); }), "WriteOptions::format");
}

TEST(IoFormatRegistry, BuiltInFormatsAreRecognisedByContent) {
  TempDir dir;
  const Volume v = test::io::random_volume({6, 5, 4}, DType::i16, 3);
  for (const char* name : {"v.nrrd", "v.nii", "v.tif"}) {
    write_volume(dir / name, v);
    const fs::path renamed = dir / (std::string(name) + ".dat");
    fs::copy_file(dir / name, renamed);
    EXPECT_EQ(&detect_format(renamed), &detect_format(dir / name)) << name;
    EXPECT_EQ(read_volume(renamed), read_volume(dir / name)) << name;
  }
  // Raw samples have no signature: the name must say what they are.
  write_volume(dir / "v.raw", v);
  fs::copy_file(dir / "v.raw", dir / "raw.dat");
  EXPECT_NE(test::error_of([&] { detect_format(dir / "raw.dat"); }).find("unknown volume format"), std::string::npos);
  // Writing never looks at the old content: an existing NRRD named .dat is no output format.
  EXPECT_THROW(output_format(dir / "v.nrrd.dat"), Error);
}

TEST(IoFormatRegistry, FoldersGoToTheFormatThatTakesFolders) {
  TempDir dir;
  fs::create_directory(dir / "slices");
  fs::create_directory(dir / "named.raw");  // a raw file cannot be a folder
  EXPECT_EQ(detect_format(dir / "slices").name, "tiff");
  EXPECT_EQ(detect_format(dir / "named.raw").name, "tiff");
  EXPECT_EQ(output_format(dir / "slices").name, "tiff");
}

TEST(IoFormatRegistry, RawFilesOpenAloneOnlyBesideTheirSidecar) {
  TempDir dir;
  const VolumeFormat& raw = *find_format("raw");
  ASSERT_TRUE(raw.opens_alone);
  write_volume(dir / "with.raw", toy_volume());
  std::ofstream(dir / "without.raw") << "abcd";
  EXPECT_TRUE(raw.opens_alone(dir / "with.raw"));
  EXPECT_FALSE(raw.opens_alone(dir / "without.raw"));
  EXPECT_FALSE(find_format("nrrd")->opens_alone);  // every NRRD file says its own layout
}

TEST(IoFormatRegistry, CapabilitiesOfTheBuiltIns) {
  for (const char* name : {"raw", "nrrd", "nifti", "tiff"}) {
    const VolumeFormat& f = *find_format(name);
    EXPECT_TRUE(f.capabilities.streaming) << name;
    EXPECT_TRUE(f.capabilities.spatial_metadata) << name;
    EXPECT_EQ(f.capabilities.multi_volume, std::string(name) != "raw") << name;
    EXPECT_EQ(f.read_dtypes, DTypeSet::all()) << name;
    EXPECT_EQ(bool(f.sniff), std::string(name) != "raw") << name;
  }
  EXPECT_EQ(find_format("nifti")->label_dtypes(),
            (DTypeSet{DType::u8, DType::u16, DType::i16, DType::u32, DType::i32, DType::u64, DType::i64}));
  EXPECT_EQ(find_format("tiff")->directory.empty(), false);
  EXPECT_EQ(DTypeSet::all().without(DType::f64).list().size(), 9u);
}

// The acceptance rule of the registry: outside tests and docs, a format's extension is a string
// literal in one place only, its registry entry, and the other extensions Strata names are one
// constant each (file_names.hpp). A second literal means a list that bypasses the registry.
TEST(IoFormatRegistry, EveryExtensionIsSpelledOnceInTheSources) {
  const fs::path root = fs::path(STRATA_TEST_DATA_DIR).parent_path().parent_path();
  if (!fs::is_directory(root / "src") || !fs::is_directory(root / "apps")) GTEST_SKIP() << "no source tree at " << root;
  std::vector<std::pair<fs::path, std::string>> sources;
  for (const char* folder : {"src", "apps", "include", "python/src"}) {
    if (!fs::is_directory(root / folder)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(root / folder)) {
      const std::string ext = entry.path().extension().string();
      if (!entry.is_regular_file() || (ext != ".cpp" && ext != ".hpp" && ext != ".h")) continue;
      std::ifstream in(entry.path());
      std::stringstream text;
      text << in.rdbuf();
      sources.emplace_back(entry.path(), text.str());
    }
  }
  std::vector<std::string> extensions{std::string(kStrataExtension), std::string(kPngExtension),
                                      std::string(kTemporarySuffix)};
  for (const VolumeFormat* f : formats())
    if (f->name != "toy") extensions.insert(extensions.end(), f->extensions.begin(), f->extensions.end());
  for (const std::string& ext : extensions) {
    const std::string literal = "\"" + ext + "\"";
    std::vector<std::string> places;
    for (const auto& [path, text] : sources)
      for (std::size_t at = text.find(literal); at != std::string::npos; at = text.find(literal, at + 1)) {
        // Comments may quote an extension; code may not.
        const std::size_t line_start = text.rfind('\n', at) + 1;  // npos + 1 == 0 on the first line
        const std::size_t comment = text.find("//", line_start);
        if (comment < at) continue;
        places.push_back(fs::relative(path, root).string());
      }
    EXPECT_EQ(places.size(), 1u) << literal << " appears in: " << testing::PrintToString(places);
  }
}

TEST(IoFormatRegistry, NameWithoutExtensionDropsTheLongestFormatExtension) {
  EXPECT_EQ(name_without_extension("/data/ch2better.nii.gz"), "ch2better");
  EXPECT_EQ(name_without_extension("scan.v2.NRRD"), "scan.v2");
  EXPECT_EQ(name_without_extension("cells.strata"), "cells");
  EXPECT_EQ(name_without_extension("brain.ome.zarr"), "brain");
  EXPECT_EQ(name_without_extension("notes.txt"), "notes.txt");
  EXPECT_EQ(name_without_extension(".nrrd"), "");
}

}  // namespace
}  // namespace strata::io
