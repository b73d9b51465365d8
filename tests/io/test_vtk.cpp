// VTK image data: hand-written .vti files in every encoding VTK writes (ascii, base64 inline,
// raw and base64 appended, zlib blocks, big-endian, UInt64 headers, Direction, extents that do
// not start at 0) and legacy .vtk files (ASCII, BINARY) read to the exact samples and geometry;
// what our writer stores reads back; hostile headers are refused naming the file and field.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <string>
#include <vector>

#include "io/io_test_util.hpp"
#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;
using test::io::expect_error;
using test::io::random_volume;
using test::io::write_bytes;
using test::io::write_text;

std::string base64(const std::vector<std::byte>& bytes) {
  static constexpr char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    std::uint32_t v = std::to_integer<std::uint32_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= std::to_integer<std::uint32_t>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= std::to_integer<std::uint32_t>(bytes[i + 2]);
    out += kDigits[v >> 18 & 63];
    out += kDigits[v >> 12 & 63];
    out += i + 1 < bytes.size() ? kDigits[v >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[v & 63] : '=';
  }
  return out;
}

// Appends `value` in `order`.
template <class T>
void put(std::vector<std::byte>& out, T value, std::endian order = std::endian::little) {
  auto bits = std::bit_cast<std::array<std::byte, sizeof(T)>>(value);
  if (order != std::endian::native) std::reverse(bits.begin(), bits.end());
  out.insert(out.end(), bits.begin(), bits.end());
}

template <class T>
std::vector<std::byte> samples_bytes(const std::vector<T>& values, std::endian order = std::endian::little) {
  std::vector<std::byte> out;
  for (T v : values) put(out, v, order);
  return out;
}

std::string vti(const std::string& file_attributes, const std::string& image_attributes, const std::string& arrays,
                const std::string& appended = "") {
  return "<?xml version=\"1.0\"?>\n<!-- written by hand -->\n<VTKFile type=\"ImageData\" version=\"1.0\" " +
         file_attributes + ">\n <ImageData " + image_attributes + ">\n  <Piece Extent=\"" +
         image_attributes.substr(image_attributes.find('"') + 1,
                                 image_attributes.find('"', image_attributes.find('"') + 1) -
                                     image_attributes.find('"') - 1) +
         "\">\n   <PointData Scalars=\"s\">\n" + arrays + "   </PointData>\n   <CellData/>\n  </Piece>\n </ImageData>\n" +
         appended + "</VTKFile>\n";
}

// 3 x 2 x 2 int16 samples 0, -1, 2, -3, ... (x fastest).
std::vector<std::int16_t> ramp() {
  std::vector<std::int16_t> v(12);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = std::int16_t(i % 2 ? -int(i) : int(i));
  return v;
}

void expect_ramp(const Volume& got) {
  ASSERT_EQ(got.dims(), (Extent{3, 2, 2}));
  ASSERT_EQ(got.dtype(), DType::i16);
  const auto expected = ramp();
  const auto s = got.samples<std::int16_t>();
  EXPECT_TRUE(std::equal(s.begin(), s.end(), expected.begin()));
}

constexpr const char* kImage = "WholeExtent=\"0 2 0 1 0 1\" Origin=\"1 2 3\" Spacing=\"0.5 0.25 2\"";

TEST(IoVtk, AsciiWithDirectionAndShiftedExtent) {
  TempDir dir;
  std::string values;
  for (auto v : ramp()) values += std::to_string(v) + " ";
  // x runs along world y, y along -x: point (i, j, k) = origin + D diag(s) (i, j, k).
  write_text(dir / "a.vti",
             vti("byte_order=\"LittleEndian\"",
                 "WholeExtent=\"2 4 0 1 -1 0\" Origin=\"1 2 3\" Spacing=\"0.5 0.25 2\" Direction=\"0 -1 0 1 0 0 0 0 1\"",
                 "    <DataArray type=\"Int16\" Name=\"s\" format=\"ascii\">\n " + values + "\n    </DataArray>\n"));
  auto source = open_volume(dir / "a.vti");
  expect_ramp(source->read_all());
  const VolumeInfo& info = source->info();
  EXPECT_EQ(info.spacing, (Spacing{0.5, 0.25, 2}));
  const Geometry& g = info.geometry;
  // Voxel 0 is index (2, 0, -1): origin + (0, 2 * 0.5, -1 * 2).
  EXPECT_DOUBLE_EQ(g.origin[0], 1);
  EXPECT_DOUBLE_EQ(g.origin[1], 3);
  EXPECT_DOUBLE_EQ(g.origin[2], 1);
  EXPECT_DOUBLE_EQ(g.direction[1][0], 1);   // axis x along world y
  EXPECT_DOUBLE_EQ(g.direction[0][1], -1);  // axis y along world -x
  EXPECT_DOUBLE_EQ(g.direction[2][2], 1);
  EXPECT_EQ(g.unit, "");
}

TEST(IoVtk, InlineBase64UInt32Header) {
  TempDir dir;
  std::vector<std::byte> payload;
  put(payload, std::uint32_t(24));
  const auto data = samples_bytes(ramp());
  payload.insert(payload.end(), data.begin(), data.end());
  write_text(dir / "b.vti", vti("byte_order=\"LittleEndian\"", kImage,
                                "<DataArray type=\"Int16\" Name=\"s\" format=\"binary\">\n" + base64(payload) +
                                    "\n</DataArray>\n"));
  expect_ramp(read_volume(dir / "b.vti"));
  EXPECT_EQ(open_volume(dir / "b.vti")->info().geometry.origin, (Vector3{1, 2, 3}));
}

TEST(IoVtk, DecodedArraysLiveInAnUnnamedTemporaryFile) {
  TempDir dir, temp;
  std::vector<std::byte> payload;
  put(payload, std::uint32_t(24));
  const auto data = samples_bytes(ramp());
  payload.insert(payload.end(), data.begin(), data.end());
  write_text(dir / "b.vti", vti("", kImage, "<DataArray type=\"Int16\" Name=\"s\" format=\"binary\">" + base64(payload) +
                                                "</DataArray>\n"));
  ReadOptions options;
  options.temp_dir = temp.path();
  auto source = open_volume(dir / "b.vti", options);
  EXPECT_TRUE(test::io::maps_a_file_in(temp.path()));
  EXPECT_EQ(test::io::file_count(temp.path()), 0u);
  expect_ramp(source->read_box(Box{{0, 0, 0}, {3, 2, 2}}));
}

TEST(IoVtk, NegativeSpacingFlipsTheAxis) {
  TempDir dir;
  write_text(dir / "n.vti", vti("", "WholeExtent=\"0 1 0 0 0 0\" Origin=\"10 0 0\" Spacing=\"-2 1 1\"",
                                "<DataArray type=\"UInt8\" Name=\"s\" format=\"ascii\">1 2</DataArray>\n"));
  const VolumeInfo info = open_volume(dir / "n.vti")->info();
  EXPECT_EQ(info.spacing, (Spacing{2, 1, 1}));
  EXPECT_DOUBLE_EQ(info.geometry.direction[0][0], -1);
  EXPECT_DOUBLE_EQ(info.geometry.origin[0], 10);
}

TEST(IoVtk, RawAppendedBigEndianUInt64Header) {
  TempDir dir;
  const std::vector<double> values{1.5, -2.25, 1e300, 0, 4, 5, 6, 7, 8, 9, 10, -11};
  std::vector<std::byte> raw;
  // A first array (UInt8, 12 bytes) before ours, so our offset is not 0.
  put(raw, std::uint64_t(12), std::endian::big);
  raw.insert(raw.end(), 12, std::byte{7});
  const std::size_t offset = raw.size();
  put(raw, std::uint64_t(96), std::endian::big);
  const auto data = samples_bytes(values, std::endian::big);
  raw.insert(raw.end(), data.begin(), data.end());
  const std::string head = vti("byte_order=\"BigEndian\" header_type=\"UInt64\"", kImage,
                               "<DataArray type=\"UInt8\" Name=\"mask\" format=\"appended\" offset=\"0\"/>\n"
                               "<DataArray type=\"Float64\" Name=\"s\" format=\"appended\" offset=\"" +
                                   std::to_string(offset) + "\"/>\n",
                               "<AppendedData encoding=\"raw\">\n  _@@\n</AppendedData>\n");
  std::string text = head.substr(0, head.find("@@"));
  std::vector<std::byte> file(reinterpret_cast<const std::byte*>(text.data()),
                              reinterpret_cast<const std::byte*>(text.data()) + text.size());
  file.insert(file.end(), raw.begin(), raw.end());
  const std::string tail = head.substr(head.find("@@") + 2);
  file.insert(file.end(), reinterpret_cast<const std::byte*>(tail.data()),
              reinterpret_cast<const std::byte*>(tail.data()) + tail.size());
  write_bytes(dir / "c.vti", file);
  const Volume v = read_volume(dir / "c.vti");  // Scalars="s": the second array
  ASSERT_EQ(v.dtype(), DType::f64);
  EXPECT_TRUE(std::ranges::equal(v.samples<double>(), values));
  ReadOptions mask;
  mask.dataset = "mask";
  const Volume m = open_volume(dir / "c.vti", mask)->read_all();
  EXPECT_EQ(m.dtype(), DType::u8);
  EXPECT_EQ(m.samples<std::uint8_t>()[5], 7);
  mask.dataset = "missing";
  expect_error([&] { open_volume(dir / "c.vti", mask); }, {"c.vti", "DataArray Name", "\"missing\"", "\"mask\""});
}

// The zlib header VTK writes: block count, block size, last block size, compressed sizes, then
// the blocks; `block` bytes a block.
std::pair<std::vector<std::byte>, std::vector<std::byte>> zlib_blocks(const std::vector<std::byte>& data,
                                                                      std::size_t block, std::endian order) {
  std::vector<std::byte> header, blocks;
  const std::size_t count = (data.size() + block - 1) / block;
  put(header, std::uint32_t(count), order);
  put(header, std::uint32_t(block), order);
  put(header, std::uint32_t(data.size() % block), order);
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t n = std::min(block, data.size() - i * block);
    uLongf size = compressBound(uLong(n));
    std::vector<std::byte> c(size);
    compress2(reinterpret_cast<Bytef*>(c.data()), &size, reinterpret_cast<const Bytef*>(data.data() + i * block), uLong(n), 9);
    put(header, std::uint32_t(size), order);
    blocks.insert(blocks.end(), c.begin(), c.begin() + std::ptrdiff_t(size));
  }
  return {header, blocks};
}

TEST(IoVtk, ZlibBlocksInlineAndAppendedBase64) {
  TempDir dir;
  const auto data = samples_bytes(ramp(), std::endian::big);
  const auto [header, blocks] = zlib_blocks(data, 10, std::endian::big);  // 3 blocks: 10, 10, 4 bytes
  // Inline: VTK encodes the header and the blocks as two base64 runs.
  write_text(dir / "z.vti", vti("byte_order=\"BigEndian\" compressor=\"vtkZLibDataCompressor\"", kImage,
                                "<DataArray type=\"Int16\" Name=\"s\" format=\"binary\">" + base64(header) +
                                    base64(blocks) + "</DataArray>\n"));
  expect_ramp(read_volume(dir / "z.vti"));
  write_text(dir / "za.vti", vti("byte_order=\"BigEndian\" compressor=\"vtkZLibDataCompressor\"", kImage,
                                 "<DataArray type=\"Int16\" Name=\"s\" format=\"appended\" offset=\"0\"/>\n",
                                 "<AppendedData encoding=\"base64\">\n _" + base64(header) + base64(blocks) +
                                     "\n</AppendedData>\n"));
  auto source = open_volume(dir / "za.vti");
  const Volume box = source->read_box(Box{{1, 1, 1}, {3, 2, 2}});
  EXPECT_EQ(box.samples<std::int16_t>()[0], ramp()[10]);
  EXPECT_EQ(box.samples<std::int16_t>()[1], ramp()[11]);
}

TEST(IoVtk, ComponentsAreVolumes) {
  TempDir dir;
  write_text(dir / "v.vti", vti("", "WholeExtent=\"0 1 0 0 0 0\"",
                                "<DataArray type=\"UInt64\" Name=\"s\" NumberOfComponents=\"2\" format=\"ascii\">"
                                "1 18446744073709551615 3 4</DataArray>\n"));
  expect_error([&] { open_volume(dir / "v.vti"); }, {"v.vti", "2 volumes", "--volume"});
  ReadOptions second;
  second.volume = 1;
  const Volume v = open_volume(dir / "v.vti", second)->read_all();
  ASSERT_EQ(v.dtype(), DType::u64);
  EXPECT_EQ(v.samples<std::uint64_t>()[0], 18446744073709551615ull);
  EXPECT_EQ(v.samples<std::uint64_t>()[1], 4u);
}

TEST(IoVtk, LegacyAsciiAndBinary) {
  TempDir dir;
  write_text(dir / "a.vtk",
             "# vtk DataFile Version 3.0\nhand made\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\n"
             "ASPECT_RATIO 0.5 0.25 2\nORIGIN 1 2 3\nPOINT_DATA 12\nSCALARS first float\nLOOKUP_TABLE default\n"
             "0 0 0 0 0 0 0 0 0 0 0 0\nSCALARS s short 1\nLOOKUP_TABLE default\n0 -1 2 -3 4 -5 6 -7 8 -9 10 -11\n");
  ReadOptions named;
  named.dataset = "s";
  auto ascii = open_volume(dir / "a.vtk", named);
  expect_ramp(ascii->read_all());
  EXPECT_EQ(ascii->info().spacing, (Spacing{0.5, 0.25, 2}));
  EXPECT_EQ(ascii->info().geometry.origin, (Vector3{1, 2, 3}));
  EXPECT_EQ(read_volume(dir / "a.vtk").dtype(), DType::f32);  // the first array by default

  std::string head =
      "# vtk DataFile Version 3.0\nbinary\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\nSPACING 1 1 1\n"
      "ORIGIN 0 0 0\nPOINT_DATA 12\nSCALARS s short\nLOOKUP_TABLE default\n";
  std::vector<std::byte> file(reinterpret_cast<const std::byte*>(head.data()),
                              reinterpret_cast<const std::byte*>(head.data()) + head.size());
  const auto data = samples_bytes(ramp(), std::endian::big);
  file.insert(file.end(), data.begin(), data.end());
  write_bytes(dir / "b.vtk", file);
  expect_ramp(read_volume(dir / "b.vtk"));
}

TEST(IoVtk, WriterRoundTripsEveryTypeAndGeometry) {
  TempDir dir;
  for (DType t : kAllDTypes)
    for (const char* name : {"z.vti", "u.vti", "l.vtk"}) {
      Volume v = random_volume({5, 4, 3}, t, 11);
      VolumeInfo info = v.info();
      info.geometry.origin = {-1.5, 2, 1e-3};
      if (name[0] != 'l') info.geometry.direction = {{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}};
      WriteOptions options;
      options.compress = name[0] == 'z';
      auto writer = create_volume_writer(dir / name, info, options);
      writer->write_slab(v.crop(Box{{0, 0, 0}, {5, 4, 2}}));
      writer->write_slab(v.crop(Box{{0, 0, 2}, {5, 4, 3}}));
      writer->finish();
      auto source = open_volume(dir / name);
      test::io::expect_same(source->read_all(), v, std::string(name) + " " + std::string(dtype_name(t)));
      EXPECT_EQ(source->info().geometry.origin, info.geometry.origin) << name;
      EXPECT_EQ(source->info().geometry.direction, info.geometry.direction) << name;
    }
  VolumeInfo rotated = random_volume({2, 2, 2}, DType::u8, 1).info();
  rotated.geometry.direction = {{{0, 1, 0}, {1, 0, 0}, {0, 0, 1}}};
  expect_error([&] { create_volume_writer(dir / "r.vtk", rotated); }, {"r.vtk", "direction", ".vti"});
}

TEST(IoVtk, CompressedWriterSpansSeveralBlocks) {
  TempDir dir;
  const Volume v = random_volume({256, 128, 40}, DType::u16, 3);  // 2.5 MiB: three 1 MiB blocks
  write_volume(dir / "big.vti", v);
  const std::string text = test::io::read_text(dir / "big.vti");
  EXPECT_NE(text.find("compressor=\"vtkZLibDataCompressor\""), std::string::npos);
  auto source = open_volume(dir / "big.vti");
  test::io::expect_same(source->read_box(Box{{3, 5, 17}, {200, 100, 39}}), v.crop(Box{{3, 5, 17}, {200, 100, 39}}));
}

TEST(IoVtk, HostileInputIsRefusedNamingTheField) {
  TempDir dir;
  const auto refuse = [&](const std::string& name, const std::string& text, std::vector<std::string> parts) {
    write_text(dir / name, text);
    parts.insert(parts.begin(), name);
    expect_error([&] { open_volume(dir / name)->read_all(); }, parts);
  };
  const std::string ascii = "<DataArray type=\"UInt8\" Name=\"s\" format=\"ascii\">1 2</DataArray>\n";
  refuse("overflow.vti", vti("", "WholeExtent=\"0 9223372036854775806 0 9223372036854775806 0 3\"", ascii),
         {"WholeExtent", "64-bit"});
  refuse("backwards.vti", vti("", "WholeExtent=\"-9223372036854775808 9223372036854775807 0 0 0 0\"", ascii),
         {"WholeExtent"});
  refuse("comp0.vti", vti("", "WholeExtent=\"0 1 0 0 0 0\"",
                          "<DataArray type=\"UInt8\" Name=\"s\" NumberOfComponents=\"0\" format=\"ascii\">1 2</DataArray>"),
         {"NumberOfComponents", "0"});
  refuse("comphuge.vti", vti("", "WholeExtent=\"0 1 0 0 0 0\"",
                             "<DataArray type=\"UInt8\" Name=\"s\" NumberOfComponents=\"99999999999\" format=\"ascii\">"
                             "1 2</DataArray>"),
         {"NumberOfComponents"});
  refuse("type.vti", vti("", "WholeExtent=\"0 1 0 0 0 0\"", "<DataArray type=\"Bit\" Name=\"s\" format=\"ascii\">1 2</DataArray>"),
         {"DataArray type", "Bit"});
  refuse("short.vti", vti("", "WholeExtent=\"0 2 0 0 0 0\"", ascii), {"DataArray \"s\"", "truncated"});
  refuse("range.vti", vti("", "WholeExtent=\"0 1 0 0 0 0\"", "<DataArray type=\"UInt8\" Name=\"s\" format=\"ascii\">1 256</DataArray>"),
         {"DataArray \"s\"", "256"});
  std::vector<std::byte> payload;
  put(payload, std::uint32_t(24));
  const auto data = samples_bytes(ramp());
  payload.insert(payload.end(), data.begin(), data.end());
  const std::string encoded = base64(payload);
  refuse("b64.vti", vti("", kImage, "<DataArray type=\"Int16\" Name=\"s\" format=\"binary\">" + encoded.substr(0, 30) + "</DataArray>"),
         {"DataArray \"s\"", "truncated"});
  refuse("b64bad.vti", vti("", kImage, "<DataArray type=\"Int16\" Name=\"s\" format=\"binary\">AAAA*AAA</DataArray>"),
         {"DataArray \"s\"", "invalid base64"});
  // Blocks whose table says 12 bytes each while they decode to 10 (and 4).
  auto [header, blocks] = zlib_blocks(samples_bytes(ramp()), 10, std::endian::little);
  std::vector<std::byte> lying;
  put(lying, std::uint32_t(2));
  put(lying, std::uint32_t(12));
  put(lying, std::uint32_t(0));
  lying.insert(lying.end(), header.begin() + 12, header.begin() + 20);
  std::vector<std::byte> two_blocks(blocks.begin(), blocks.begin() + std::ptrdiff_t(std::to_integer<int>(header[12]) +
                                                                                      std::to_integer<int>(header[16])));
  refuse("zsize.vti", vti("compressor=\"vtkZLibDataCompressor\"", kImage,
                          "<DataArray type=\"Int16\" Name=\"s\" format=\"binary\">" + base64(lying) + base64(two_blocks) +
                              "</DataArray>"),
         {"DataArray \"s\"", "block 0", "12 bytes"});
  std::vector<std::byte> many;
  put(many, std::uint32_t(4000000000u));
  put(many, std::uint32_t(1));
  put(many, std::uint32_t(0));
  refuse("zmany.vti", vti("compressor=\"vtkZLibDataCompressor\"", kImage,
                          "<DataArray type=\"Int16\" Name=\"s\" format=\"binary\">" + base64(many) + "</DataArray>"),
         {"DataArray \"s\"", "4000000000 compressed blocks"});
  refuse("compressor.vti", vti("compressor=\"vtkLZ4DataCompressor\"", kImage, ascii), {"compressor", "vtkLZ4DataCompressor"});
  refuse("offset.vti", vti("", kImage, "<DataArray type=\"Int16\" Name=\"s\" format=\"appended\" offset=\"999\"/>",
                           "<AppendedData encoding=\"raw\">_</AppendedData>"),
         {"offset", "999"});
  refuse("xml.vti", "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 0 0 0 0 0\">", {"XML", "never closed"});
  std::string deep = "<VTKFile type=\"ImageData\">";
  for (int i = 0; i < 100; ++i) deep += "<a>";
  refuse("deep.vti", deep, {"XML", "nested"});
  refuse("points.vtk", "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nPOINT_DATA 9\n",
         {"POINT_DATA", "9"});
  refuse("dims.vtk",
         "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4294967296 4294967296 2\n"
         "POINT_DATA 1\n",
         {"POINT_DATA"});
  refuse("grid.vtk", "# vtk DataFile Version 3.0\nt\nASCII\nDATASET RECTILINEAR_GRID\n", {"DATASET", "rectilinear_grid"});
  refuse("bin.vtk",
         "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4 4 4\nPOINT_DATA 64\n"
         "SCALARS s double\nLOOKUP_TABLE default\n1234",
         {"SCALARS s"});
}

}  // namespace
}  // namespace strata::io
