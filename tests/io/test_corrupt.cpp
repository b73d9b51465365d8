// Broken inputs fail loudly with the file and the field in the message; broken writes leave
// nothing behind.
#include <gtest/gtest.h>

#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

using namespace strata::test::io;

Volume ramp_volume(Extent dims, DType t) {
  Volume v(dims, t);
  std::int64_t i = 0;
  for (std::int64_t z = 0; z < dims.z; ++z)
    for (std::int64_t y = 0; y < dims.y; ++y)
      for (std::int64_t x = 0; x < dims.x; ++x) v.set_value(x, y, z, double(i++ % 120));
  return v;
}

void expect_open_error(const std::filesystem::path& path, const std::vector<std::string>& needles,
                       const ReadOptions& options = {}) {
  SCOPED_TRACE(path.string());
  std::vector<std::string> all = needles;
  all.push_back(path.filename().string());
  expect_error([&] { open_volume(path, options)->read_all(); }, all);
}

std::string nrrd_header(const std::string& fields) { return "NRRD0004\n" + fields + "\n"; }

const std::string kGoodFields = "type: uint16\ndimension: 3\nsizes: 4 3 2\nendian: little\n";

TEST(IoCorrupt, TruncatedRawNrrd) {
  test::TempDir dir;
  write_text(dir / "t.nrrd", nrrd_header(kGoodFields + "encoding: raw\n") + std::string(47, 'x'));
  expect_open_error(dir / "t.nrrd", {"data", "47", "48", "truncated"});
}

TEST(IoCorrupt, TruncatedGzipNrrd) {
  test::TempDir dir;
  write_volume(dir / "whole.nrrd", ramp_volume({40, 30, 20}, DType::u16));
  const std::string whole = read_text(dir / "whole.nrrd");
  write_text(dir / "cut.nrrd", whole.substr(0, whole.size() - 100));
  expect_open_error(dir / "cut.nrrd", {"data", "truncated"});
  // Cut right after the header: no gzip data at all.
  write_text(dir / "empty.nrrd", whole.substr(0, whole.find("\n\n") + 2));
  expect_open_error(dir / "empty.nrrd", {"data"});
}

TEST(IoCorrupt, BadGzipStream) {
  test::TempDir dir;
  write_volume(dir / "whole.nrrd", ramp_volume({40, 30, 20}, DType::u16));
  std::string bytes = read_text(dir / "whole.nrrd");
  // Overwrite the middle of the deflate data; the stream or its CRC check must fail.
  const std::size_t middle = bytes.find("\n\n") + 2 + 40;
  for (std::size_t i = middle; i < middle + 16 && i < bytes.size(); ++i) bytes[i] = char(0xA5 ^ i);
  write_text(dir / "bad.nrrd", bytes);
  expect_open_error(dir / "bad.nrrd", {"data", "gzip"});
  // Not gzip at all although the header says so.
  write_text(dir / "plain.nrrd", nrrd_header(kGoodFields + "encoding: gzip\n") + std::string(48, 'x'));
  expect_open_error(dir / "plain.nrrd", {"data", "gzip"});
}

TEST(IoCorrupt, WrongSizes) {
  test::TempDir dir;
  const std::string data(48, 'x');  // 4x3x2 u16
  // Header promises more data than there is, and less: both mean the sizes are wrong.
  write_text(dir / "more.nrrd", nrrd_header("type: uint16\ndimension: 3\nsizes: 4 3 3\nendian: little\n"
                                            "encoding: raw\n") + data);
  expect_open_error(dir / "more.nrrd", {"data", "sizes"});
  write_text(dir / "less.nrrd", nrrd_header("type: uint16\ndimension: 3\nsizes: 4 3 1\nendian: little\n"
                                            "encoding: raw\n") + data);
  expect_open_error(dir / "less.nrrd", {"data", "sizes"});
  // Gzip data that decodes to the wrong length.
  write_volume(dir / "g.nrrd", ramp_volume({4, 3, 3}, DType::u16));
  std::string g = read_text(dir / "g.nrrd");
  g.replace(g.find("sizes: 4 3 3"), 12, "sizes: 4 3 2");
  write_text(dir / "gless.nrrd", g);
  expect_open_error(dir / "gless.nrrd", {"data", "sizes"});
  // Malformed sizes fields.
  write_text(dir / "two.nrrd", nrrd_header("type: uint8\ndimension: 3\nsizes: 4 3\nencoding: raw\n") + data);
  expect_open_error(dir / "two.nrrd", {"sizes"});
  write_text(dir / "zero.nrrd", nrrd_header("type: uint8\ndimension: 3\nsizes: 4 0 3\nencoding: raw\n") + data);
  expect_open_error(dir / "zero.nrrd", {"sizes"});
  write_text(dir / "text.nrrd", nrrd_header("type: uint8\ndimension: 3\nsizes: 4 x 3\nencoding: raw\n") + data);
  expect_open_error(dir / "text.nrrd", {"sizes"});
}

TEST(IoCorrupt, UnknownOrUnsupportedType) {
  test::TempDir dir;
  write_text(dir / "u.nrrd", nrrd_header("type: quaternion\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n") + "x");
  expect_open_error(dir / "u.nrrd", {"type", "quaternion"});
  write_text(dir / "b.nrrd", nrrd_header("type: block\ndimension: 3\nsizes: 1 1 1\nendian: little\n"
                                         "encoding: raw\n") + std::string(8, 'x'));
  expect_open_error(dir / "b.nrrd", {"type", "block"});
}

TEST(IoCorrupt, HeaderProblemsNameTheirField) {
  test::TempDir dir;
  const std::string one = "x";
  write_text(dir / "enc.nrrd", nrrd_header("type: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: bzip2\n") + one);
  expect_open_error(dir / "enc.nrrd", {"encoding", "bzip2"});
  write_text(dir / "noenc.nrrd", nrrd_header("type: uint8\ndimension: 3\nsizes: 1 1 1\n") + one);
  expect_open_error(dir / "noenc.nrrd", {"encoding", "missing"});
  write_text(dir / "endian.nrrd", nrrd_header("type: uint16\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n") + "xx");
  expect_open_error(dir / "endian.nrrd", {"endian"});
  write_text(dir / "dim.nrrd", nrrd_header("type: uint8\ndimension: 2\nsizes: 1 1\nencoding: raw\n") + one);
  expect_open_error(dir / "dim.nrrd", {"dimension"});
  write_text(dir / "magic.nrrd", "P5\n1 1\n255\n" + one);
  expect_open_error(dir / "magic.nrrd", {"magic"});
  write_text(dir / "empty.nrrd", "");
  expect_open_error(dir / "empty.nrrd", {"empty file (0 bytes)"});
  write_text(dir / "junk.nrrd", nrrd_header("type: uint8\nthis line has no colon\n") + one);
  expect_open_error(dir / "junk.nrrd", {"header", "line 3"});
  write_text(dir / "sp.nrrd", nrrd_header("type: uint8\ndimension: 3\nsizes: 1 1 1\nspacings: 1 one 1\n"
                                          "encoding: raw\n") + one);
  expect_open_error(dir / "sp.nrrd", {"spacings", "one"});
}

TEST(IoCorrupt, DetachedHeaderProblems) {
  test::TempDir dir;
  write_text(dir / "nodata.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n");
  expect_open_error(dir / "nodata.nhdr", {"data file"});
  write_text(dir / "missing.nhdr",
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nencoding: raw\ndata file: gone.raw\n");
  expect_open_error(dir / "missing.nhdr", {"gone.raw"});
  write_text(dir / "list.nhdr",
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 2\nencoding: raw\ndata file: LIST\na.raw\nb.raw\n");
  expect_open_error(dir / "list.nhdr", {"data file"});
}

TEST(IoCorrupt, RawWithoutSidecarOrOptions) {
  test::TempDir dir;
  write_text(dir / "lonely.raw", std::string(64, 'x'));
  expect_open_error(dir / "lonely.raw", {"ReadOptions::raw_dims: ", "dims", "dtype", "sidecar"});
  ReadOptions only_dims;
  only_dims.raw_dims = Extent{4, 4, 4};
  expect_open_error(dir / "lonely.raw", {"ReadOptions::raw_dtype: ", "sidecar"}, only_dims);
}

TEST(IoCorrupt, BadSidecars) {
  test::TempDir dir;
  write_text(dir / "a.raw", std::string(8, 'x'));
  write_text(dir / "a.raw.json", "{\"dims\": [2, 2, 2], \"dtype\": ");
  expect_error([&] { open_volume(dir / "a.raw"); }, {"a.raw.json", "json"});
  write_text(dir / "a.raw.json", R"({"dims":[2,2,2],"dtype":"u128"})");
  expect_error([&] { open_volume(dir / "a.raw"); }, {"a.raw.json", "dtype", "u128"});
  write_text(dir / "a.raw.json", R"({"dims":[2,-2,2],"dtype":"u8"})");
  expect_error([&] { open_volume(dir / "a.raw"); }, {"a.raw.json", "dims"});
  write_text(dir / "a.raw.json", R"({"dims":[2,2],"dtype":"u8"})");
  expect_error([&] { open_volume(dir / "a.raw"); }, {"a.raw.json", "dims"});
  write_text(dir / "a.raw.json", R"({"dims":[2,2,2],"dtype":"u16"})");
  expect_open_error(dir / "a.raw", {"size", "expected 16 bytes for 2x2x2 u16, found 8"});
}

TEST(IoCorrupt, UnfinishedWritersLeaveNothing) {
  test::TempDir dir;
  const Volume slab = ramp_volume({6, 5, 2}, DType::u16);
  const VolumeInfo info{{6, 5, 4}, DType::u16, {}};
  for (const char* name : {"a.raw", "b.nrrd", "c.nhdr"}) {
    for (bool compress : {true, false}) {
      SCOPED_TRACE(std::string(name) + (compress ? " gzip" : " raw"));
      auto writer = create_volume_writer(dir / name, info, with_compression(compress));
      writer->write_slab(slab);
      EXPECT_GE(file_count(dir.path()), 1u);  // the temporary exists while writing
      writer.reset();                         // dropped without finish(), as after an exception
      EXPECT_EQ(file_count(dir.path()), 0u);
    }
  }
}

TEST(IoCorrupt, FailedWriteKeepsAnExistingOutputIntact) {
  test::TempDir dir;
  const Volume good = ramp_volume({6, 5, 4}, DType::u16);
  write_volume(dir / "keep.nrrd", good);
  const std::string before = read_text(dir / "keep.nrrd");
  {
    auto writer = create_volume_writer(dir / "keep.nrrd", good.info());
    writer->write_slab(good.crop({{0, 0, 0}, {6, 5, 1}}));
    EXPECT_THROW(writer->finish(), Error);  // 1 of 4 slices
  }
  EXPECT_EQ(read_text(dir / "keep.nrrd"), before);
  EXPECT_EQ(file_count(dir.path()), 1u);
}

}  // namespace
}  // namespace strata::io
