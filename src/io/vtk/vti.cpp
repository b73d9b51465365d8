// VTK XML image data (.vti), read. The elements and attributes read:
// | element    | attribute                  | meaning here                                          |
// | ---------- | -------------------------- | ----------------------------------------------------- |
// | VTKFile    | type                       | must be "ImageData"                                   |
// |            | byte_order                 | LittleEndian (default) or BigEndian: binary samples   |
// |            | header_type                | UInt32 (default) or UInt64: the binary header's words |
// |            | compressor                 | none or vtkZLibDataCompressor                         |
// | ImageData  | WholeExtent                | x0 x1 y0 y1 z0 z1, inclusive: dims = x1 - x0 + 1, ... |
// |            | Origin, Spacing            | 3 numbers each (defaults 0 and 1)                     |
// |            | Direction                  | 9 numbers, row-major; column c is index axis c        |
// | Piece      | Extent                     | one piece, covering WholeExtent                       |
// | PointData  | Scalars                    | the array read by default                             |
// | DataArray  | type, Name                 | Int8 .. Float64, Int64, UInt64; ReadOptions::dataset  |
// |            | NumberOfComponents         | 1 by default; several: one volume each                |
// |            | format                     | ascii, binary (base64 inline) or appended             |
// |            | offset                     | appended: bytes after AppendedData's '_'              |
// | AppendedData | encoding                 | raw or base64                                         |
// Binary data is [header][samples]: the header is the byte count (uncompressed) or the block table
// (compressed, decode.cpp). Raw appended uncompressed samples are memory-mapped in place;
// everything else is decoded once into a temporary file that is mapped.
#include <fmt/format.h>

#include "io/vtk/vtk_detail.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::vtk {

namespace {

struct FileAttributes {
  BinaryHeaderFormat header;
  bool compressed = false;
};

const XmlElement& find_element(const XmlDocument& doc, std::string_view name, const std::string& file) {
  for (const XmlElement& e : doc.elements)
    if (e.name == name) return e;
  throw FormatError(file, name == "VTKFile" ? "VTKFile" : std::string(name), fmt::format("no <{}> element", name));
}

std::string attribute_or(const XmlElement& e, std::string_view key, std::string fallback) {
  const std::string* v = e.attribute(key);
  return v ? *v : fallback;
}

FileAttributes file_attributes(const XmlElement& root, const std::string& file) {
  const std::string type = attribute_or(root, "type", "");
  if (type != "ImageData")
    throw FormatError(file, "VTKFile type", fmt::format("\"{}\" is not read (only ImageData)", type));
  FileAttributes a;
  const std::string order = attribute_or(root, "byte_order", "LittleEndian");
  if (order != "LittleEndian" && order != "BigEndian")
    throw FormatError(file, "VTKFile byte_order", fmt::format("\"{}\" (expected LittleEndian or BigEndian)", order));
  a.header.big_endian = order == "BigEndian";
  const std::string header_type = attribute_or(root, "header_type", "UInt32");
  if (header_type != "UInt32" && header_type != "UInt64")
    throw FormatError(file, "VTKFile header_type", fmt::format("\"{}\" (expected UInt32 or UInt64)", header_type));
  a.header.word_bytes = header_type == "UInt64" ? 8 : 4;
  const std::string compressor = attribute_or(root, "compressor", "");
  if (!compressor.empty() && compressor != "vtkZLibDataCompressor")
    throw FormatError(file, "VTKFile compressor",
                      fmt::format("\"{}\" is not read (only vtkZLibDataCompressor, or none)", compressor));
  a.compressed = !compressor.empty();
  return a;
}

// The DataArray to read: ReadOptions::dataset by Name, else PointData's Scalars, else the first.
const XmlElement& choose_array(const XmlDocument& doc, const ReadOptions& options, const std::string& file) {
  std::vector<const XmlElement*> arrays;
  const XmlElement* point_data = nullptr;
  for (const XmlElement& e : doc.elements) {
    if (e.name == "PointData" && e.parent == "Piece" && !point_data) point_data = &e;
    if (e.name == "DataArray" && e.parent == "PointData") arrays.push_back(&e);
  }
  if (arrays.empty()) throw FormatError(file, "PointData", "no point data array (cell data is not read)");
  std::string wanted = options.dataset;
  if (wanted.empty() && point_data) wanted = attribute_or(*point_data, "Scalars", "");
  if (wanted.empty()) return *arrays.front();
  std::vector<std::string> names;
  for (const XmlElement* a : arrays) {
    const std::string name = attribute_or(*a, "Name", "");
    if (name == wanted) return *a;
    names.push_back("\"" + name + "\"");
  }
  throw FormatError(file, options.dataset.empty() ? "PointData Scalars" : "DataArray Name",
                    fmt::format("no point data array named \"{}\" (the file has {})", wanted, fmt::join(names, ", ")));
}

// Dims and the first index of an inclusive extent "x0 x1 y0 y1 z0 z1".
std::pair<Extent, Vector3> extent_dims(const std::string& text, const std::string& file, const std::string& field) {
  const std::vector<std::int64_t> e = parse_ints(text, 6, file, field);
  std::int64_t n[3];
  for (int a = 0; a < 3; ++a) {
    std::int64_t span = 0;
    if (__builtin_sub_overflow(e[2 * a + 1], e[2 * a], &span) || span < 0 || span == std::numeric_limits<std::int64_t>::max())
      throw FormatError(file, field, fmt::format("\"{}\": every axis needs its end >= its start, within 64 bits", text));
    n[a] = span + 1;
  }
  return {Extent{n[0], n[1], n[2]}, Vector3{double(e[0]), double(e[2]), double(e[4])}};
}

ArrayLayout image_layout(const XmlDocument& doc, const XmlElement& array, const std::string& file) {
  const XmlElement& image = find_element(doc, "ImageData", file);
  const std::string whole = attribute_or(image, "WholeExtent", "");
  const auto [dims, first] = extent_dims(whole, file, "ImageData WholeExtent");
  std::size_t pieces = 0;
  for (const XmlElement& e : doc.elements)
    if (e.name == "Piece" && e.parent == "ImageData") {
      ++pieces;
      const std::string extent = attribute_or(e, "Extent", whole);
      if (parse_ints(extent, 6, file, "Piece Extent") != parse_ints(whole, 6, file, "ImageData WholeExtent"))
        throw FormatError(file, "Piece Extent", fmt::format("\"{}\" is not the WholeExtent \"{}\" (pieces of a larger image are not read)", extent, whole));
    }
  if (pieces != 1) throw FormatError(file, "Piece", fmt::format("{} pieces (one is read)", pieces));
  const auto three = [&](std::string_view key, const char* fallback) {
    const auto v = parse_doubles(attribute_or(image, key, fallback), 3, file, "ImageData " + std::string(key));
    return Vector3{v[0], v[1], v[2]};
  };
  const auto d = parse_doubles(attribute_or(image, "Direction", "1 0 0 0 1 0 0 0 1"), 9, file, "ImageData Direction");
  const Matrix3 direction{{{d[0], d[1], d[2]}, {d[3], d[4], d[5]}, {d[6], d[7], d[8]}}};

  const std::string type = attribute_or(array, "type", "");
  const std::optional<DType> dtype = dtype_of_xml_type(type);
  if (!dtype)
    throw FormatError(file, "DataArray type",
                      fmt::format("\"{}\" is not read (expected Int8, UInt8, ..., Int64, UInt64, Float32, Float64)", type));
  const std::vector<std::int64_t> components =
      parse_ints(attribute_or(array, "NumberOfComponents", "1"), 1, file, "DataArray NumberOfComponents");
  if (components[0] < 1 || components[0] > kMaxComponents)
    throw FormatError(file, "DataArray NumberOfComponents", fmt::format("{} (expected 1..{})", components[0], kMaxComponents));
  return array_layout(dims, first, *dtype, components[0], three("Origin", "0 0 0"), three("Spacing", "1 1 1"), direction,
                      file, "ImageData Spacing, Direction", "ImageData WholeExtent");
}

// Samples of an inline or appended array that are not raw and uncompressed: decoded to a
// temporary file, left in the file's byte order.
std::shared_ptr<MappedFile> decode_binary(ByteReader in, const FileAttributes& attributes, const ArrayLayout& layout,
                                          std::uint64_t available, const ReadOptions& options, const std::string& file,
                                          const std::string& field) {
  DecodedSamples out(options, file, field, layout.bytes);
  if (attributes.compressed) {
    inflate_blocks(in, attributes.header, layout.bytes, available, out, file, field);
  } else {
    read_byte_count(in, attributes.header, layout.bytes, file, field);
    std::vector<std::byte> chunk(std::min<std::uint64_t>(layout.bytes, 1 << 20));
    for (std::uint64_t left = layout.bytes; left > 0;) {
      const auto take = std::size_t(std::min<std::uint64_t>(left, chunk.size()));
      read_exactly(in, chunk.data(), take, file, field);
      out.write(chunk.data(), take);
      left -= take;
    }
  }
  return out.map();
}

}  // namespace

std::unique_ptr<VolumeSource> open_vti(const std::filesystem::path& path, const ReadOptions& options) {
  const std::string file = path.string();
  auto mapped = std::make_shared<MappedFile>(path);
  const std::string_view text(reinterpret_cast<const char*>(mapped->data()), mapped->size());
  const XmlDocument doc = scan_xml(text, file);
  const FileAttributes attributes = file_attributes(find_element(doc, "VTKFile", file), file);
  const XmlElement& array = choose_array(doc, options, file);
  const ArrayLayout layout = image_layout(doc, array, file);
  const std::string name = attribute_or(array, "Name", "");
  const std::string field = fmt::format("DataArray \"{}\"", name);
  const std::string format = attribute_or(array, "format", "");

  if (format == "ascii") {
    DecodedSamples out(options, file, field, layout.bytes);
    parse_ascii_samples(array.text, layout.info.dtype, layout.bytes / dtype_size(layout.info.dtype), &out, file, field);
    return component_source(out.map(), 0, layout, false, path, options, field);
  }
  if (format == "binary") {
    const auto decoded = decode_binary(base64_reader(array.text, file, field), attributes, layout, array.text.size(),
                                       options, file, field);
    return component_source(decoded, 0, layout, attributes.header.big_endian, path, options, field);
  }
  if (format != "appended")
    throw FormatError(file, field + " format", fmt::format("\"{}\" (expected ascii, binary or appended)", format));

  const XmlElement& appended = find_element(doc, "AppendedData", file);
  if (!doc.appended) throw FormatError(file, "AppendedData", "no '_' marker before the data");
  const std::vector<std::int64_t> offset = parse_ints(attribute_or(array, "offset", ""), 1, file, field + " offset");
  const std::uint64_t start = *doc.appended;
  if (offset[0] < 0 || std::uint64_t(offset[0]) > mapped->size() - start)
    throw FormatError(file, field + " offset", fmt::format("{} lies outside the appended data", offset[0]));
  const std::uint64_t at = start + std::uint64_t(offset[0]);
  const std::byte* data = mapped->data() + at;
  const std::uint64_t available = mapped->size() - at;
  const std::string encoding = attribute_or(appended, "encoding", "raw");
  if (encoding == "base64") {
    // The array's text ends where the appended data's next array or the closing tag begins.
    const std::string_view rest = text.substr(at);
    const std::string_view encoded = rest.substr(0, std::min(rest.find_first_not_of(
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/= \t\r\n"), rest.size()));
    const auto decoded = decode_binary(base64_reader(encoded, file, field), attributes, layout, encoded.size(), options,
                                       file, field);
    return component_source(decoded, 0, layout, attributes.header.big_endian, path, options, field);
  }
  if (encoding != "raw")
    throw FormatError(file, "AppendedData encoding", fmt::format("\"{}\" (expected raw or base64)", encoding));
  ByteReader in = region_reader(data, available);
  if (attributes.compressed) {
    const auto decoded = decode_binary(std::move(in), attributes, layout, available, options, file, field);
    return component_source(decoded, 0, layout, attributes.header.big_endian, path, options, field);
  }
  read_byte_count(in, attributes.header, layout.bytes, file, field);
  return component_source(std::move(mapped), at + attributes.header.word_bytes, layout, attributes.header.big_endian,
                          path, options, field);
}

}  // namespace strata::io::detail::vtk
