// VTK image data written: XML .vti with raw appended data (zlib blocks when compressed), and
// legacy BINARY .vtk STRUCTURED_POINTS. Both stream slab by slab into a temporary file renamed
// at finish().
//
// .vti layout: the XML header (one DataArray at appended offset 0, header_type UInt64), then
// AppendedData's '_' and the array: uncompressed, its byte count and the samples; compressed, the
// block table (decode.cpp), whose size is known from the volume's (the block count is fixed), as a
// placeholder patched at finish() once every block's compressed size is known, then the blocks.
#include <zlib.h>

#include <span>

#include <fmt/format.h>

#include "io/vtk/vtk_detail.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::vtk {

namespace {

// Uncompressed size of a zlib block: what VTK's readers decode at a time, so 1 MiB keeps them
// (and ours) light.
constexpr std::uint64_t kBlockBytes = 1 << 20;
constexpr std::string_view kArrayName = "ImageScalars";

std::string three(double a, double b, double c) { return fmt::format("{} {} {}", a, b, c); }

std::string vti_header(const VolumeInfo& info, bool compress) {
  const Extent& d = info.dims;
  const Geometry& g = info.geometry;
  const std::string extent = fmt::format("0 {} 0 {} 0 {}", d.x - 1, d.y - 1, d.z - 1);
  std::string direction;
  for (const Vector3& row : g.direction) direction += fmt::format("{}{} {} {}", direction.empty() ? "" : " ", row[0], row[1], row[2]);
  return fmt::format(
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"{}>\n"
      "  <ImageData WholeExtent=\"{}\" Origin=\"{}\" Spacing=\"{}\" Direction=\"{}\">\n"
      "    <Piece Extent=\"{}\">\n"
      "      <PointData Scalars=\"{}\">\n"
      "        <DataArray type=\"{}\" Name=\"{}\" format=\"appended\" offset=\"0\"/>\n"
      "      </PointData>\n"
      "      <CellData>\n"
      "      </CellData>\n"
      "    </Piece>\n"
      "  </ImageData>\n"
      "  <AppendedData encoding=\"raw\">\n"
      "   _",
      compress ? " compressor=\"vtkZLibDataCompressor\"" : "", extent, three(g.origin[0], g.origin[1], g.origin[2]),
      three(info.spacing.x, info.spacing.y, info.spacing.z), direction, extent, kArrayName,
      xml_type_name(info.dtype), kArrayName);
}

constexpr std::string_view kVtiTrailer = "\n  </AppendedData>\n</VTKFile>\n";

class VtiWriter final : public VolumeWriter {
 public:
  VtiWriter(const std::filesystem::path& path, const VolumeInfo& info, bool compress)
      : out_(path), total_(info.byte_size()), compress_(compress) {
    const std::string header = vti_header(info, compress);
    out_.write(header.data(), header.size());
    table_offset_ = header.size();
    if (compress_) {
      blocks_ = (total_ + kBlockBytes - 1) / kBlockBytes;
      const std::vector<std::uint64_t> placeholder(3 + blocks_);
      out_.write(placeholder.data(), placeholder.size() * sizeof(std::uint64_t));
      block_.reserve(std::size_t(std::min(total_, kBlockBytes)));
    } else {
      out_.write(&total_, sizeof total_);
    }
  }

  void write_slab(const Volume& slab) override {
    if (!compress_) return out_.write(slab.bytes(), slab.byte_size());
    const std::byte* data = slab.bytes();
    for (std::size_t left = slab.byte_size(); left > 0;) {
      const std::size_t take = std::min<std::size_t>(left, kBlockBytes - block_.size());
      block_.insert(block_.end(), data, data + take);
      data += take;
      left -= take;
      if (block_.size() == kBlockBytes) flush_block();
    }
  }

  void finish() override {
    if (compress_) {
      if (!block_.empty()) flush_block();
      patch_block_table();
    }
    out_.write(kVtiTrailer.data(), kVtiTrailer.size());
    out_.commit();
  }

 private:
  void flush_block() {
    uLongf size = compressBound(uLong(block_.size()));
    compressed_.resize(size);
    if (compress2(reinterpret_cast<Bytef*>(compressed_.data()), &size, reinterpret_cast<const Bytef*>(block_.data()),
                  uLong(block_.size()), Z_DEFAULT_COMPRESSION) != Z_OK)
      throw Error(fmt::format("{}: zlib compression failed", out_.path().string()));
    out_.write(compressed_.data(), size);
    sizes_.push_back(size);
    block_.clear();
  }

  void patch_block_table() {
    std::vector<std::uint64_t> table{blocks_, kBlockBytes, total_ % kBlockBytes};
    table.insert(table.end(), sizes_.begin(), sizes_.end());
    patch_output(out_, table_offset_, std::as_bytes(std::span(table)), "the compressed blocks' sizes");
  }

  AtomicOutputFile out_;
  std::uint64_t total_;
  bool compress_;
  std::size_t table_offset_ = 0;
  std::uint64_t blocks_ = 0;
  std::vector<std::byte> block_, compressed_;
  std::vector<std::uint64_t> sizes_;
};

// Legacy files are big-endian: each slab is swapped on its way out.
class LegacyWriter final : public VolumeWriter {
 public:
  LegacyWriter(const std::filesystem::path& path, const VolumeInfo& info) : out_(path) {
    const Extent& d = info.dims;
    const Vector3& o = info.geometry.origin;
    const std::string header = fmt::format(
        "# vtk DataFile Version 3.0\nStrata volume\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS {} {} {}\n"
        "SPACING {}\nORIGIN {}\nPOINT_DATA {}\nSCALARS {} {} 1\nLOOKUP_TABLE default\n",
        d.x, d.y, d.z, three(info.spacing.x, info.spacing.y, info.spacing.z), three(o[0], o[1], o[2]), d.voxel_count(),
        kArrayName, legacy_type_name(info.dtype));
    out_.write(header.data(), header.size());
  }
  void write_slab(const Volume& slab) override {
    Volume swapped = slab;
    byte_swap(swapped.bytes(), std::size_t(swapped.dims().voxel_count()), dtype_size(swapped.dtype()));
    out_.write(swapped.bytes(), swapped.byte_size());
  }
  void finish() override {
    out_.write("\n", 1);
    out_.commit();
  }

 private:
  AtomicOutputFile out_;
};

}  // namespace

std::unique_ptr<VolumeWriter> create_vti_writer(const std::filesystem::path& path, const VolumeInfo& info, bool compress) {
  return std::make_unique<VtiWriter>(path, info, compress);
}

std::unique_ptr<VolumeWriter> create_legacy_writer(const std::filesystem::path& path, const VolumeInfo& info) {
  if (info.geometry.direction != kIdentity3)
    throw Error(fmt::format("{}: legacy VTK STRUCTURED_POINTS has no direction cosines and this volume is rotated; "
                            "write .vti, which keeps them",
                            path.string()));
  return std::make_unique<LegacyWriter>(path, info);
}

}  // namespace strata::io::detail::vtk
