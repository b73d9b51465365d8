#pragma once
// Steps of encode_labels that the distributed driver (src/dist/labels.cpp) runs on its part of
// a label volume: they are shared so that both make the same file.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <span>
#include <variant>
#include <vector>

#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/mixture/id_storage.hpp"
#include "strata/mixture/label_map.hpp"

namespace strata::mixture::detail {

// Level 0's node ids (its source ids) in the layout `mode` asks for, built as they stream past
// or from parts that other ranks built of the next slices.
class Level0Ids {
 public:
  Level0Ids(const Extent& dims, std::uint32_t sources, IdsMode mode);
  void append(std::span<const std::uint32_t> ids) {
    std::visit([&](auto& b) { b.append(ids); }, builder_);
  }
  // A part as part_bytes() of a Level0Ids of the next slices (same x-y extent, sources, mode).
  void append_part(std::span<const std::byte> part);
  // Consumes the builder: its ids serialized without compression (a part to send).
  std::vector<std::byte> part_bytes();
  // Consumes the builder: the ids_L0 section (zstd-compressed when `options` ask).
  std::vector<std::byte> section(const EncodeOptions& options);

 private:
  std::variant<BlockPaletteIds::Builder, FixedRateIds::Builder> builder_;
};

// The label values of slices `span` of `source`, read `slab` slices at a time.
LabelMap collect_label_map(io::VolumeSource& source, io::SliceSpan span, std::int64_t slab, ProgressSink& progress);

// Slices `span` of `source`, read `slab` slices at a time (a multiple of 8 unless it ends the
// volume), mapped to source ids under `map` into `mipmap` and `level0`.
void stream_ids(io::VolumeSource& source, io::SliceSpan span, std::int64_t slab, const LabelMap& map,
                HistogramMipmap::StreamBuilder& mipmap, Level0Ids& level0, ProgressSink& progress);

// What the streaming passes produce: the label map, the mipmap without level 0, level 0's id
// section and the count of background voxels.
struct StreamedLabels {
  LabelMap map;
  HistogramMipmap mipmap;
  std::vector<std::byte> level0_section;
  std::uint64_t zero_voxels = 0;
};

// Completes the streamed passes over the whole volume (builds the coarser levels).
StreamedLabels finish_streamed(LabelMap map, HistogramMipmap::StreamBuilder& mipmap, Level0Ids& level0,
                               const EncodeOptions& options, ProgressSink& progress);

// Factorises the mipmap and writes the file; `whole` is the volume in memory when the normals
// graph needs it (null otherwise), `start` when encoding began (for the report's seconds).
EncodeReport write_labels_file(StreamedLabels s, const VolumeInfo& info, const Volume* whole,
                               const std::filesystem::path& out, const EncodeOptions& options, ProgressSink& progress,
                               std::chrono::steady_clock::time_point start);

}  // namespace strata::mixture::detail
