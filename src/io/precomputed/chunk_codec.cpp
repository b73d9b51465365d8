// The chunk encodings of volume.md: raw (little-endian, x fastest, then y, z, channel), jpeg (a
// 1- or 3-component image whose rows, concatenated, are the x-fastest voxels; components are the
// channels) and compressed_segmentation (compressed_segmentation.hpp).
#include "io/precomputed/chunk_codec.hpp"

#include <turbojpeg.h>

#include <cstring>
#include <memory>

#include <fmt/format.h>

#include "io/precomputed/compressed_segmentation.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::precomputed {

namespace {

using Bytes = std::vector<std::byte>;

std::uint64_t voxels_of(const Extent& e) { return std::uint64_t(e.x) * std::uint64_t(e.y) * std::uint64_t(e.z); }

Bytes decode_raw(const Bytes& encoded, const Extent& extent, const VolumeDescription& d, std::int64_t channel,
                 const std::string& file) {
  const std::uint64_t channel_bytes = voxels_of(extent) * dtype_size(d.dtype);
  if (encoded.size() != channel_bytes * std::uint64_t(d.channels))
    throw FormatError(file, "chunk",
                      fmt::format("{} bytes, a raw chunk of {} voxels x {} channels of {} has {}", encoded.size(),
                                  extent.to_string(), d.channels, dtype_name(d.dtype), channel_bytes * d.channels));
  const auto first = encoded.begin() + std::ptrdiff_t(channel_bytes * std::uint64_t(channel));
  return Bytes(first, first + std::ptrdiff_t(channel_bytes));
}

Bytes decode_jpeg(const Bytes& encoded, const Extent& extent, const VolumeDescription& d, std::int64_t channel,
                  const std::string& file) {
  const std::unique_ptr<void, int (*)(tjhandle)> jpeg(tjInitDecompress(), tjDestroy);
  if (!jpeg) throw Error("cannot start the JPEG decoder");
  const auto* data = reinterpret_cast<const unsigned char*>(encoded.data());
  int width = 0, height = 0, subsampling = 0, colorspace = 0;
  const auto fail = [&](const std::string& problem) -> void { throw FormatError(file, "jpeg", problem); };
  if (tjDecompressHeader3(jpeg.get(), data, encoded.size(), &width, &height, &subsampling, &colorspace) != 0)
    fail(tjGetErrorStr2(jpeg.get()));
  if (std::uint64_t(width) * std::uint64_t(height) != voxels_of(extent))
    fail(fmt::format("a {}x{} image cannot hold a chunk of {} voxels", width, height, extent.to_string()));
  const int components = int(d.channels);
  Bytes pixels(voxels_of(extent) * std::uint64_t(components));
  if (tjDecompress2(jpeg.get(), data, encoded.size(), reinterpret_cast<unsigned char*>(pixels.data()), width, 0, height,
                    components == 1 ? TJPF_GRAY : TJPF_RGB, TJFLAG_ACCURATEDCT) != 0)
    fail(tjGetErrorStr2(jpeg.get()));
  if (components == 1) return pixels;
  Bytes out(voxels_of(extent));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = pixels[i * std::size_t(components) + std::size_t(channel)];
  return out;
}

// A grayscale image `extent.x` wide and `extent.y * extent.z` high: the rows, concatenated, are
// the voxels x fastest, as decode_jpeg reads them (and Neuroglancer).
Bytes encode_jpeg(const std::byte* samples, const Extent& extent, int quality) {
  const std::unique_ptr<void, int (*)(tjhandle)> jpeg(tjInitCompress(), tjDestroy);
  if (!jpeg) throw Error("cannot start the JPEG encoder");
  unsigned char* out = nullptr;
  unsigned long size = 0;
  const int width = int(extent.x), height = int(extent.y * extent.z);
  const int rc = tjCompress2(jpeg.get(), reinterpret_cast<const unsigned char*>(samples), width, 0, height, TJPF_GRAY,
                             &out, &size, TJSAMP_GRAY, quality, TJFLAG_ACCURATEDCT);
  const std::unique_ptr<unsigned char, void (*)(unsigned char*)> owned(out, tjFree);
  if (rc != 0)
    throw Error(fmt::format("cannot encode a {} chunk as JPEG: {}", extent.to_string(), tjGetErrorStr2(jpeg.get())));
  const auto* first = reinterpret_cast<const std::byte*>(out);
  return Bytes(first, first + size);
}

}  // namespace

std::uint64_t max_encoded_chunk_bytes(const Extent& extent, const VolumeDescription& d) {
  // compressed_segmentation of 1-voxel uint32 blocks takes 12 bytes a voxel: a header and a table entry.
  return (4 * voxels_of(extent) * dtype_size(d.dtype) + 4096) * std::uint64_t(d.channels);
}

Bytes decode_chunk(const Bytes& encoded, const Extent& extent, const Scale& scale, const VolumeDescription& d,
                   std::int64_t channel, const std::string& file) {
  switch (scale.encoding) {
    case ChunkEncoding::raw: return decode_raw(encoded, extent, d, channel, file);
    case ChunkEncoding::jpeg: return decode_jpeg(encoded, extent, d, channel, file);
    case ChunkEncoding::compressed_segmentation: {
      Bytes out(voxels_of(extent) * dtype_size(d.dtype));
      decode_compressed_segmentation(encoded, extent, scale.block, d.channels, channel, d.dtype, out.data(), file);
      return out;
    }
  }
  throw Error("unknown chunk encoding");
}

Bytes encode_chunk(const std::byte* samples, const Extent& extent, const Scale& scale, DType dtype) {
  if (scale.encoding == ChunkEncoding::compressed_segmentation)
    return encode_compressed_segmentation(samples, extent, scale.block, dtype);
  if (scale.encoding == ChunkEncoding::jpeg) {
    if (dtype != DType::u8) throw Error(fmt::format("jpeg chunks hold u8 samples, not {}", dtype_name(dtype)));
    return encode_jpeg(samples, extent, scale.jpeg_quality);
  }
  return Bytes(samples, samples + voxels_of(extent) * dtype_size(dtype));
}

}  // namespace strata::io::detail::precomputed
