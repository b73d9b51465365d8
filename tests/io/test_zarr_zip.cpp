// Zarr zip stores: what zarr-python's ZipStore writes (stored members by default, deflated ones
// too; an array and an OME-Zarr group) reads back equal to the source; zips built here with zip64
// records, a top folder (`zip -r`), a group of arrays and a sharded array inside; damaged zips
// refused naming the file and field; the writer refuses a .zip name.
#include <gtest/gtest.h>

#include <zlib.h>

#include <cstring>
#include <functional>

#include "io/zarr_test_util.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::error_of;
using test::TempDir;
using test::zarr::expect_refused;

// zarr-python 2 (Debian's python3-zarr) writes a u16 array and an OME-Zarr 0.4 group into zip
// stores, stored and deflated, and the samples as raw little-endian u16 beside them.
const char* kWriteScript = R"(
import sys, zipfile, numpy, zarr, numcodecs
out = sys.argv[1]
a = numpy.random.default_rng(3).integers(0, 65535, size=(9, 10, 11), dtype='<u2')
a.tofile(out + '/a.u16')
for name, compression in (('stored', zipfile.ZIP_STORED), ('deflated', zipfile.ZIP_DEFLATED)):
    store = zarr.ZipStore(out + '/' + name + '.zarr.zip', mode='w', compression=compression)
    z = zarr.create(a.shape, chunks=(4, 4, 4), dtype='<u2', store=store, compressor=numcodecs.Blosc(cname='zstd'), fill_value=0)
    z[...] = a
    store.close()
store = zarr.ZipStore(out + '/image.ome.zarr.zip', mode='w')
root = zarr.group(store=store)
root.attrs['multiscales'] = [{'version': '0.4', 'axes': [{'name': n, 'type': 'space', 'unit': 'micrometer'} for n in 'zyx'],
    'datasets': [{'path': '0', 'coordinateTransformations': [{'type': 'scale', 'scale': [2.0, 1.5, 0.5]}]}]}]
root.create_dataset('0', data=a, chunks=(3, 5, 7), compressor=numcodecs.Zlib(level=3))
store.close()
)";

Volume samples_of(const fs::path& file, Spacing spacing) {
  Volume v({11, 10, 9}, DType::u16, spacing);
  const std::vector<std::byte> bytes = test::io::read_bytes(file);
  EXPECT_EQ(bytes.size(), v.byte_size());
  std::memcpy(v.bytes(), bytes.data(), std::min(bytes.size(), v.byte_size()));
  return v;
}

TEST(IoZarrZip, WhatZarrPythonZipStoreWritesReadsBackExactly) {
  TempDir dir;
  test::io::write_bytes(dir / "write.py", kWriteScript, std::strlen(kWriteScript));
  std::string out;
  if (test::run_command("/usr/bin/python3 -c 'import zarr, numcodecs' 2>&1", &out) != 0)
    GTEST_SKIP() << "python3-zarr not installed: " << out;
  ASSERT_EQ(test::run_command("/usr/bin/python3 " + test::shell_quoted(dir / "write.py") + " " + test::shell_quoted(dir.path()) + " 2>&1", &out), 0) << out;
  for (const char* name : {"stored.zarr.zip", "deflated.zarr.zip", "image.ome.zarr.zip"}) {
    const bool image = std::string(name).starts_with("image");
    const Volume expected = samples_of(dir / "a.u16", image ? Spacing{0.5, 1.5, 2.0} : Spacing{1, 1, 1});
    EXPECT_EQ(detect_format(dir / name).name, "zarr");
    auto source = open_volume(dir / name);
    test::io::expect_same(source->read_all(), expected, name);
    const Box box{{3, 2, 1}, {11, 9, 8}};
    EXPECT_TRUE(source->read_box(box) == expected.crop(box)) << name;
  }
}

// A zip file built member by member (APPNOTE 6.3), stored or deflated, optionally with zip64
// records (extra fields in the central directory, the zip64 end record and locator).
class ZipBuilder {
 public:
  void add(const std::string& name, const std::vector<std::byte>& data, bool deflate = false) {
    Entry e{name, data.size(), std::uint32_t(crc32(0, reinterpret_cast<const Bytef*>(data.data()), uInt(data.size()))),
            std::uint64_t(bytes_.size()), deflate};
    const std::vector<std::byte> stored = deflate ? test::zarr::deflate_bytes(data, -15) : data;
    e.compressed = stored.size();
    u32(bytes_, 0x04034b50), u16(bytes_, 20), u16(bytes_, 0), u16(bytes_, deflate ? 8 : 0), u32(bytes_, 0);
    u32(bytes_, e.crc), u32(bytes_, std::uint32_t(e.compressed)), u32(bytes_, std::uint32_t(e.plain));
    u16(bytes_, std::uint16_t(name.size())), u16(bytes_, 0);
    append(bytes_, name);
    bytes_.insert(bytes_.end(), stored.begin(), stored.end());
    entries_.push_back(e);
  }
  void add(const std::string& name, const std::string& text) { add(name, test::zarr::text_bytes(text)); }

  // The whole zip; `patch` may change an entry's central directory fields before they are written.
  std::vector<std::byte> finish(bool zip64, const std::function<void(std::size_t, std::uint64_t&, std::uint64_t&, std::uint64_t&)>& patch = {}) {
    std::vector<std::byte> out = bytes_;
    const std::uint64_t directory_at = out.size();
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      Entry e = entries_[i];
      if (patch) patch(i, e.offset, e.compressed, e.plain);
      const std::uint32_t sat = 0xFFFFFFFF;
      u32(out, 0x02014b50), u16(out, 45), u16(out, 45), u16(out, 0), u16(out, e.deflate ? 8 : 0), u32(out, 0);
      u32(out, e.crc);
      u32(out, zip64 ? sat : std::uint32_t(e.compressed)), u32(out, zip64 ? sat : std::uint32_t(e.plain));
      u16(out, std::uint16_t(e.name.size())), u16(out, zip64 ? 28 : 0), u16(out, 0), u16(out, 0), u16(out, 0), u32(out, 0);
      u32(out, zip64 ? sat : std::uint32_t(e.offset));
      append(out, e.name);
      if (zip64) u16(out, 1), u16(out, 24), u64(out, e.plain), u64(out, e.compressed), u64(out, e.offset);
    }
    const std::uint64_t directory_size = out.size() - directory_at, n = entries_.size();
    if (zip64) {
      const std::uint64_t end64_at = out.size();
      u32(out, 0x06064b50), u64(out, 44), u16(out, 45), u16(out, 45), u32(out, 0), u32(out, 0);
      u64(out, n), u64(out, n), u64(out, directory_size), u64(out, directory_at);
      u32(out, 0x07064b50), u32(out, 0), u64(out, end64_at), u32(out, 1);
    }
    u32(out, 0x06054b50), u16(out, 0), u16(out, 0);
    u16(out, zip64 ? 0xFFFF : std::uint16_t(n)), u16(out, zip64 ? 0xFFFF : std::uint16_t(n));
    u32(out, zip64 ? 0xFFFFFFFF : std::uint32_t(directory_size)), u32(out, zip64 ? 0xFFFFFFFF : std::uint32_t(directory_at));
    u16(out, 0);
    return out;
  }

 private:
  struct Entry {
    std::string name;
    std::uint64_t plain;
    std::uint32_t crc;
    std::uint64_t offset;
    bool deflate;
    std::uint64_t compressed = 0;
  };
  template <class T>
  static int put(std::vector<std::byte>& out, T v) {
    for (std::size_t i = 0; i < sizeof(T); ++i) out.push_back(std::byte((std::uint64_t(v) >> (8 * i)) & 0xFF));
    return 0;
  }
  static int u16(std::vector<std::byte>& out, std::uint16_t v) { return put(out, v); }
  static int u32(std::vector<std::byte>& out, std::uint32_t v) { return put(out, v); }
  static int u64(std::vector<std::byte>& out, std::uint64_t v) { return put(out, v); }
  static void append(std::vector<std::byte>& out, const std::string& s) {
    for (char c : s) out.push_back(std::byte(c));
  }
  std::vector<std::byte> bytes_;
  std::vector<Entry> entries_;
};

json v2_array(json shape, json chunks) {
  return {{"zarr_format", 2}, {"shape", shape}, {"chunks", chunks}, {"dtype", "<u2"}, {"compressor", nullptr},
          {"fill_value", 9},  {"order", "C"},   {"filters", nullptr}};
}

std::vector<std::byte> u16_bytes(std::vector<std::uint16_t> values) {
  std::vector<std::byte> out(values.size() * 2);
  std::memcpy(out.data(), values.data(), out.size());
  return out;
}

TEST(IoZarrZip, Zip64TopFolderGroupsAndShardsInsideAZip) {
  TempDir dir;
  // `zip -r g.zarr.zip g.zarr`: every member under "g.zarr/", a directory entry, deflated members.
  ZipBuilder zip;
  zip.add("g.zarr/", std::string());
  zip.add("g.zarr/.zgroup", R"({"zarr_format": 2})");
  zip.add("g.zarr/raw/.zarray", v2_array({1, 2, 3}, {1, 2, 2}).dump());
  zip.add("g.zarr/raw/0.0.0", u16_bytes({1, 2, 3, 4}), /*deflate=*/true);  // chunk (0, 0, 1) missing: fill 9
  zip.add("g.zarr/other/.zarray", v2_array({1, 1, 1}, {1, 1, 1}).dump());
  for (bool zip64 : {false, true}) {
    const fs::path path = dir / (zip64 ? "g64.zarr.zip" : "g.zarr.zip");
    test::io::write_bytes(path, zip.finish(zip64));
    const std::string message = error_of([&] { (void)read_volume(path); });
    EXPECT_NE(message.find("other, raw"), std::string::npos) << message;
    const Volume raw = read_volume(fs::path(path.string() + ":/raw"));
    ASSERT_EQ(raw.dims(), (Extent{3, 2, 1}));
    EXPECT_EQ(std::vector<std::uint16_t>(raw.samples<std::uint16_t>().begin(), raw.samples<std::uint16_t>().end()),
              (std::vector<std::uint16_t>{1, 2, 9, 3, 4, 9}));
  }
  // A sharded v3 array whose shards are stored members: read by range from the zip.
  const Volume v = test::io::random_volume({14, 12, 10}, DType::u16, 5, {1, 1, 1});
  test::zarr::ShardOptions o;
  o.crc32c = true;
  o.missing_shards = {{0, 1, 0}};
  const Volume expected = test::zarr::write_sharded(dir / "folder.zarr", v, o);
  ZipBuilder sharded;
  for (const auto& entry : fs::recursive_directory_iterator(dir / "folder.zarr"))
    if (entry.is_regular_file())
      sharded.add(fs::relative(entry.path(), dir / "folder.zarr").generic_string(), test::io::read_bytes(entry.path()));
  test::io::write_bytes(dir / "s.zarr.zip", sharded.finish(false));
  test::io::expect_same(read_volume(dir / "s.zarr.zip"), expected, "sharded in a zip");
}

TEST(IoZarrZip, DamagedZipsAreRefusedNamingTheFileAndField) {
  TempDir dir;
  ZipBuilder zip;
  zip.add(".zarray", v2_array({1, 2, 2}, {1, 2, 2}).dump());
  zip.add("0.0.0", u16_bytes({1, 2, 3, 4}), /*deflate=*/true);
  const auto write = [&](const std::string& name, const std::vector<std::byte>& bytes) {
    test::io::write_bytes(dir / name, bytes);
    return [p = dir / name] { (void)read_volume(p); };
  };
  // The intact zip reads.
  write("ok.zarr.zip", zip.finish(false))();
  // Not a zip at all, and a truncated one (its end record cut off).
  expect_refused(write("text.zarr.zip", test::zarr::text_bytes("not a zip")), "text.zarr.zip", "end of central directory");
  std::vector<std::byte> cut = zip.finish(false);
  cut.resize(cut.size() - 10);
  expect_refused(write("cut.zarr.zip", cut), "cut.zarr.zip", "end of central directory");
  // A member whose local header offset lies outside the file.
  const auto patched = [&](std::size_t which, std::uint64_t offset, std::uint64_t compressed, std::uint64_t plain, bool zip64) {
    return zip.finish(zip64, [=](std::size_t i, std::uint64_t& o, std::uint64_t& c, std::uint64_t& p) {
      if (i != which) return;
      if (offset) o = offset;
      if (compressed) c = compressed;
      if (plain) p = plain;
    });
  };
  expect_refused(write("offset.zarr.zip", patched(1, 1u << 30, 0, 0, false)), "offset.zarr.zip:/0.0.0", "zip member");
  // zip64 sizes that overflow when added to the offset, and one the central directory cannot hold.
  expect_refused(write("overflow.zarr.zip", patched(1, 0, ~0ull - 8, 0, true)), "overflow.zarr.zip:/0.0.0", "zip member");
  expect_refused(write("hugeplain.zarr.zip", patched(0, 0, ~0ull, ~0ull, true)), "hugeplain.zarr.zip", "metadata");
  // A deflated member that decodes to more, or fewer, bytes than the directory says.
  expect_refused(write("bigger.zarr.zip", patched(1, 0, 0, 3, false)), "bigger.zarr.zip:/0.0.0", "zip member: the deflate data");
  expect_refused(write("smaller.zarr.zip", patched(1, 0, 0, 100, false)), "smaller.zarr.zip:/0.0.0", "zip member");
  // A stored member whose sizes differ, and one whose bytes do not match their crc32.
  expect_refused(write("sizes.zarr.zip", patched(0, 0, 5, 0, false)), "sizes.zarr.zip:/.zarray", "zip member: stored");
  std::vector<std::byte> flipped = zip.finish(false);
  flipped[30 + 7 + 3] ^= std::byte{0x20};  // a letter of the stored .zarray's JSON
  expect_refused(write("crc.zarr.zip", flipped), "crc.zarr.zip:/.zarray", "zip member: crc32");
  // A central directory that claims more entries than its bytes can hold.
  std::vector<std::byte> many = zip.finish(false);
  for (std::size_t field : {8, 10}) {  // entries on this disk, and in all: 65534
    many[many.size() - 22 + field] = std::byte{0xFE};
    many[many.size() - 22 + field + 1] = std::byte{0xFF};
  }
  expect_refused(write("many.zarr.zip", many), "many.zarr.zip", "central directory");
}

TEST(IoZarrZip, ZipNamesAreZarrAndTheWriterRefusesThem) {
  EXPECT_EQ(format_by_extension("a.zarr.zip")->name, "zarr");
  EXPECT_EQ(format_by_extension("a.OME.ZARR.ZIP")->name, "zarr");
  TempDir dir;
  const Volume v = test::io::random_volume({4, 4, 4}, DType::u8, 1);
  expect_refused([&] { write_volume(dir / "out.ome.zarr.zip", v); }, "out.ome.zarr.zip", "zip stores are read, not written");
  EXPECT_FALSE(fs::exists(dir / "out.ome.zarr.zip"));
}

}  // namespace
}  // namespace strata::io
