#pragma once
// Pieces of the VTK image data reader and writer (src/io/vtk.cpp) shared by its XML (.vti) and
// legacy (.vtk) halves: VTK's sample type names, decoding of base64, zlib-compressed blocks and
// ASCII numbers into a temporary file that is then memory-mapped (so a large inline or
// compressed array is never held whole in memory), and the XML tag scanner.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "io/io_detail.hpp"
#include "strata/core/geometry.hpp"

namespace strata::io::detail::vtk {

// The XML DataArray type name ("UInt8" .. "Float64", "Int64", "UInt64") of `t`, and back.
std::string_view xml_type_name(DType t);
std::optional<DType> dtype_of_xml_type(std::string_view name);
// The legacy SCALARS type name ("unsigned_char", "vtktypeint64", ...) of `t`, and back (case
// as written; "long" and "unsigned_long" are 64-bit, as VTK writes them on 64-bit Linux).
std::string_view legacy_type_name(DType t);
std::optional<DType> dtype_of_legacy_type(std::string_view name);

// Decoded samples on their way to a mapping: an unnamed temporary file in ReadOptions::temp_dir,
// refused up front (check_temp_space) when that folder has no room for the `bytes` of `field`.
class DecodedSamples {
 public:
  DecodedSamples(const ReadOptions& options, std::string file, const std::string& field, std::uint64_t bytes);
  void write(const void* data, std::size_t bytes);
  std::uint64_t size() const { return size_; }
  // Maps what was written (the file must hold something).
  std::shared_ptr<MappedFile> map() const;

 private:
  UnnamedTempFile temp_;
  std::string file_;
  std::uint64_t size_ = 0;
};

// Where encoded bytes come from: fills `out` with up to `n` bytes, fewer only at the end.
using ByteReader = std::function<std::size_t(std::byte* out, std::size_t n)>;

// Bytes of a mapped region, read front to back.
ByteReader region_reader(const std::byte* data, std::uint64_t size);

// Base64 text decoded as it is read. Whitespace is skipped and padding ('=') ends one encoded
// run and lets another begin: VTK encodes an array's header and its data as separate runs when
// they are compressed, as one run when not, and this reads both. Any other character is a
// FormatError naming `file` and `field`.
ByteReader base64_reader(std::string_view text, std::string file, std::string field);

// Reads exactly `n` bytes or throws FormatError(file, field, "truncated ...").
void read_exactly(ByteReader& in, std::byte* out, std::size_t n, const std::string& file, const std::string& field);

// The header VTK writes before each array's bytes: either one count (uncompressed), or, with
// vtkZLibDataCompressor, [blocks, block size, last block size, compressed size of each block].
// Each number is a UInt32 or UInt64 (header_type) in the file's byte order.
struct BinaryHeaderFormat {
  std::size_t word_bytes = 4;  // 4: UInt32, 8: UInt64
  bool big_endian = false;
};

// Reads an uncompressed array's byte count and checks it against `expected`.
void read_byte_count(ByteReader& in, const BinaryHeaderFormat& format, std::uint64_t expected, const std::string& file,
                     const std::string& field);

// Reads a compressed array's block table and inflates its blocks (zlib streams) into `out`,
// checking that the blocks decode to exactly `expected` bytes in all and each to its declared
// size, and that the table is no longer than the encoded input (`available` bytes) can hold.
void inflate_blocks(ByteReader& in, const BinaryHeaderFormat& format, std::uint64_t expected, std::uint64_t available,
                    DecodedSamples& out, const std::string& file, const std::string& field);

// Parses `count` whitespace-separated numbers of `text` as `dtype` samples (native byte order)
// into `out`, or only skips them when `out` is null. Returns the offset just past the last
// number. A missing number, a word that is not a number, or a value outside the type's range is a
// FormatError naming `file` and `field`.
std::size_t parse_ascii_samples(std::string_view text, DType dtype, std::uint64_t count, DecodedSamples* out,
                                const std::string& file, const std::string& field);

// One XML element of a VTK file, as far as the reader needs it.
struct XmlElement {
  std::string name;
  std::string parent;  // the enclosing element's name ("" at the top)
  std::vector<std::pair<std::string, std::string>> attributes;
  std::string_view text;  // the character data right after the start tag (inline array data)
  // The attribute's value, or null.
  const std::string* attribute(std::string_view key) const;
};

// The elements of a VTK XML file in document order, up to <AppendedData>, whose raw bytes are no
// XML: `appended` is the file offset just past its '_' marker (std::nullopt without one).
struct XmlDocument {
  std::vector<XmlElement> elements;
  std::optional<std::uint64_t> appended;
};

// Scans the tags of `doc` (the mapped file). Malformed markup, nesting deeper than a VTK file
// needs, or more elements than one can hold is a FormatError naming `file`.
XmlDocument scan_xml(std::string_view doc, const std::string& file);

// ---------------------------------------------------------------------------------------------
// Shared by both readers (common.cpp)

// The `count` whitespace-separated numbers of `text` (an attribute, a header line); any other
// count or a word that is no finite number is a FormatError naming `file` and `field`.
std::vector<double> parse_doubles(std::string_view text, std::size_t count, const std::string& file,
                                  const std::string& field);
std::vector<std::int64_t> parse_ints(std::string_view text, std::size_t count, const std::string& file,
                                     const std::string& field);

// The most components (NumberOfComponents, legacy SCALARS' count) a reader takes, each read as one
// volume (ReadOptions::volume).
inline constexpr std::int64_t kMaxComponents = 1024;

// What a reader found: the array's layout, before its samples are located.
struct ArrayLayout {
  VolumeInfo info;  // dims, dtype, spacing, geometry; volumes = components
  std::uint64_t bytes = 0;  // of all components: dims x components x sample size
};

// Fills `layout` from VTK's image geometry: point (i, j, k) of the extent lies at
// origin + direction * diag(spacing) * (i, j, k), so voxel 0 (extent start `first`) is at
// origin + direction * diag(spacing) * first. Negative spacings flip their direction column;
// zero or non-finite ones are a FormatError naming `field`. Also checks dims x components x sample
// size against overflow (FormatError naming `size_field`).
ArrayLayout array_layout(const Extent& dims, const Vector3& first, DType dtype, std::int64_t components,
                         const Vector3& origin, const Vector3& spacing, const Matrix3& direction, const std::string& file,
                         const std::string& field, const std::string& size_field);

// The source of component ReadOptions::volume of the x-fastest, component-interleaved samples at
// `offset` of `mapped`.
std::unique_ptr<VolumeSource> component_source(std::shared_ptr<MappedFile> mapped, std::uint64_t offset,
                                               const ArrayLayout& layout, bool big_endian,
                                               const std::filesystem::path& path, const ReadOptions& options,
                                               const std::string& field);

// The two readers and writers (vti.cpp, legacy.cpp, writers.cpp).
std::unique_ptr<VolumeSource> open_vti(const std::filesystem::path& path, const ReadOptions& options);
std::unique_ptr<VolumeSource> open_legacy(const std::filesystem::path& path, const ReadOptions& options);
std::unique_ptr<VolumeWriter> create_vti_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                bool compress);
std::unique_ptr<VolumeWriter> create_legacy_writer(const std::filesystem::path& path, const VolumeInfo& info);

}  // namespace strata::io::detail::vtk
