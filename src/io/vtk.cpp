// VTK image data: XML ImageData (.vti) and legacy STRUCTURED_POINTS (.vtk), read and written
// without the VTK library. The parts live in src/io/vtk/: vti.cpp and legacy.cpp read (their
// header tables are there), decode.cpp decodes base64, zlib blocks and ASCII, xml_scan.cpp
// scans the XML tags, writers.cpp writes. A file is read by its content (the legacy signature
// line, else XML); written by its extension (.vtk legacy, else .vti).
#include <cstring>

#include "io/builtin_formats.hpp"
#include "io/vtk/vtk_detail.hpp"

namespace strata::io::detail {

namespace {

// The extension written as a legacy file; every other name is written as XML.
constexpr std::string_view kLegacyExtension = ".vtk";
constexpr std::string_view kLegacySignature = "# vtk DataFile";
constexpr std::string_view kXmlRoot = "<VTKFile";
// The XML root element comes after at most an XML declaration and a comment or two.
constexpr std::size_t kSniffBytes = 512;

bool is_legacy(std::span<const std::byte> head) {
  return head.size() >= kLegacySignature.size() &&
         std::memcmp(head.data(), kLegacySignature.data(), kLegacySignature.size()) == 0;
}

bool is_vtk(std::span<const std::byte> head) {
  const std::string_view text(reinterpret_cast<const char*>(head.data()), head.size());
  return is_legacy(head) || (text.find(kXmlRoot) != std::string_view::npos && text.find("ImageData") != std::string_view::npos);
}

std::unique_ptr<VolumeSource> open_vtk(const std::filesystem::path& path, const ReadOptions& options) {
  char head[kLegacySignature.size()]{};
  {
    const MappedFile probe(path);
    std::memcpy(head, probe.data(), std::min<std::size_t>(probe.size(), sizeof head));
  }
  if (is_legacy(std::as_bytes(std::span(head)))) return vtk::open_legacy(path, options);
  return vtk::open_vti(path, options);
}

std::unique_ptr<VolumeWriter> create_vtk_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                const WriteOptions& options) {
  if (ascii_lower(path.extension().string()) == kLegacyExtension) return vtk::create_legacy_writer(path, info);
  return vtk::create_vti_writer(path, info, options.compress);
}

}  // namespace

VolumeFormat vtk_format() {
  return {
      .name = "vtk",
      .title = "VTK image data",
      .description = "VTK's image data: XML ImageData (.vti) and legacy STRUCTURED_POINTS (.vtk), as ParaView writes them",
      .extensions = {".vti", std::string(kLegacyExtension)},
      .magic_bytes = kSniffBytes,
      .sniff = is_vtk,
      .open = open_vtk,
      .create_writer = create_vtk_writer,
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true, .datasets = true},
      .read_dtypes = DTypeSet::all(),
      .write_dtypes = DTypeSet::all(),
      .read_notes = ".vti: ascii, base64 binary or raw/base64 appended arrays, zlib-compressed or not, either byte "
                    "order, UInt32/UInt64 headers, Origin/Spacing/Direction, one piece; the array named by Scalars, "
                    "else the first, or `--dataset NAME`; components as volumes. Legacy .vtk: STRUCTURED_POINTS, "
                    "ASCII or BINARY SCALARS. Raw appended and legacy binary samples are memory-mapped, the rest "
                    "decoded once to a temporary file",
      .write_notes = ".vti with raw appended data (zlib blocks of 1 MiB unless uncompressed), Origin, Spacing and "
                     "Direction; `.vtk` as legacy BINARY STRUCTURED_POINTS (origin and spacing; no direction, so a "
                     "rotated volume is refused)",
  };
}

}  // namespace strata::io::detail
