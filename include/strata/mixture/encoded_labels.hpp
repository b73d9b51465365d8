#pragma once
// A label (segmentation) volume stored as a Mixture Graph in a .strata container
// (metadata "codec": "mixture-graph"; byte layout in docs/format.md, "Codec mixture-graph"):
//   section "mixture_graph"  the graph bitstream of paper Table 1 (header, node triples, codebook)
//   section "label_map"      the original label values (level 0 decodes bit for bit)
//   section "ids_L<n>"       per mip level n the node id of every voxel (FixedRateIds or BlockPaletteIds)
// encode_labels() builds the histogram mipmap, factorises it and writes the file atomically;
// EncodedLabels opens and validates one and serves node ids (NodeGrid), the original labels,
// dominant labels and per-label fractions of the coarser levels.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/mixture/label_names.hpp"
#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/factorize.hpp"
#include "strata/mixture/graph_bitstream.hpp"
#include "strata/mixture/id_storage.hpp"
#include "strata/mixture/label_map.hpp"
#include "strata/mixture/label_normals.hpp"
#include "strata/mixture/lookup.hpp"
#include "strata/mixture/node_grid.hpp"
#include "strata/mixture/schedule.hpp"

namespace strata::store {
class ContainerReader;
}

namespace strata::mixture {

inline constexpr const char* kMixtureCodecName = "mixture-graph";

enum class IdsMode : std::uint8_t { blocks, fixed };
std::string_view ids_mode_name(IdsMode m);   // "blocks", "fixed"
IdsMode parse_ids_mode(std::string_view name);  // throws Error

struct EncodeOptions {
  int bits = 9;                              // weight quantisation bitrate, 1..16
  PairScore strategy = PairScore::reduction;  // max-reduction
  std::uint32_t tau = 3;
  IdsMode ids = IdsMode::blocks;
  WeightBins bins = WeightBins::symmetric;
  bool measure_error = true;                 // max l1 error over all levels (costs a lookup build)
  // zstd level applied to each serialized ids_L<n> section (0 = stored as is). Readers
  // decompress once at open; random access then works on the in-memory id storage.
  int ids_zstd = 9;
  // Also store a normals Mixture Graph for pre-filtered shading (paper "Lighting"): the
  // quantized normal codes of label_normals.hpp, encoded as a label volume of their own and
  // kept whole as section "normals" (a complete nested .strata file, docs/format.md).
  bool normals = false;
  NormalOptions normal_options;
  // Bound in bytes on what the streamed encoding holds besides the table of distinct mixtures
  // and the factorisation (0 = 64 MiB slabs): the coarser mip levels' ids (one u32 per voxel,
  // 1/7 of level 0) plus the input slabs, whose size shrinks to fit. Throws ParameterError if
  // even one 8-slice slab cannot fit. With `normals` the whole volume is read as well.
  std::uint64_t memory_limit = 0;
  // Segment names stored as metadata.label_names (label_names.hpp); empty = none.
  LabelNames names;
};

/// @brief Most bits of a quantized interpolation weight (EncodeOptions::bits).
inline constexpr int kMaxWeightBits = 16;
/// @brief Highest zstd level of the id sections (EncodeOptions::ids_zstd).
inline constexpr int kMaxIdsZstdLevel = 22;

/// @brief The one check of label-encoding options: bits in [1, kMaxWeightBits], ids_zstd in
/// [0, kMaxIdsZstdLevel] and the normals' options (NormalOptions::validate). Throws
/// ParameterError naming the field; encode_labels checks this first.
void validate(const EncodeOptions& options);

/// @brief Slices per input slab of encode_labels() under `memory_limit` (0 = none): a multiple
/// of 8 (all slices when fewer). Throws ParameterError("EncodeOptions::memory_limit") when the
/// limit cannot hold the coarser levels' ids and one slab.
std::int64_t label_slab_slices(const VolumeInfo& info, std::uint64_t memory_limit);

struct EncodeReport {
  std::uint64_t nodes = 0, internal_nodes = 0, sources = 0;
  std::uint32_t depth = 0;
  std::uint64_t distinct_mixtures = 0, input_pairs = 0;
  // Paper Table 2 columns: the histogram mipmap the graph replaces.
  int mip_levels = 0;
  std::uint64_t mip_voxels = 0;               // voxels of all mip levels
  double nnz_per_voxel = 0.0;                 // mean mixture entries per voxel, all levels
  std::uint64_t raw_histogram_bytes = 0;      // sparse mipmap as (u32 id, f32 weight) pairs
  double background_fraction = 0.0;           // level-0 voxels labelled 0
  std::optional<double> max_l1;               // when measured
  std::uint64_t file_bytes = 0, graph_bytes = 0, label_map_bytes = 0;
  std::vector<std::uint64_t> ids_bytes;        // per level
  std::uint64_t level0_voxels = 0;
  double bits_per_voxel = 0.0;                // whole file / level-0 voxels
  double seconds = 0.0, factor_seconds = 0.0;
  std::uint64_t normals_bytes = 0;   // section "normals" (0 without normals)
  std::size_t names = 0;             // segment names stored (EncodeOptions::names of labels that occur)
  double normals_seconds = 0.0;      // estimating, quantizing and encoding them
};

/// @brief Encodes a label volume (integer samples) into `out`, written atomically. Both overloads
/// stream the volume in z-slabs (twice: label values, then ids), so a file source is never read
/// whole unless `options.normals` asks for the normals graph; they write identical files.
EncodeReport encode_labels(const Volume& labels, const std::filesystem::path& out, const EncodeOptions& options = {},
                           ProgressSink& progress = silent_progress());
EncodeReport encode_labels(io::VolumeSource& labels, const std::filesystem::path& out,
                           const EncodeOptions& options = {}, ProgressSink& progress = silent_progress());

class EncodedLabels final : public NodeGrid {
 public:
  explicit EncodedLabels(const std::filesystem::path& path);  // throws FormatError naming file and field
  // The same over a container already open (its index is not read again).
  explicit EncodedLabels(std::unique_ptr<store::ContainerReader> reader);
  ~EncodedLabels() override;

  // NodeGrid
  int level_count() const override { return int(level_dims_.size()); }
  Extent level_dims(int level) const override;
  std::uint32_t node_at(int level, std::int64_t x, std::int64_t y, std::int64_t z) const override;
  void decode_box(int level, const Box& box, std::span<std::uint32_t> out) const override;

  const std::filesystem::path& path() const;
  /// @brief How messages name the file (for a member of a volume set, with its number).
  const std::string& name() const;
  const MixtureGraph& graph() const { return graph_; }
  const LabelMap& label_map() const { return label_map_; }
  const Schedule& schedule() const { return schedule_; }
  const MixtureLookup& lookup() const;  // built on first use (thread-safe)
  IdsMode ids_mode() const { return ids_mode_; }
  bool ids_compressed() const { return ids_zstd_; }
  Spacing spacing() const { return spacing_; }
  /// @brief Where level 0 lies in space (origin, direction, unit), as the source file said.
  const Geometry& geometry() const { return geometry_; }
  const nlohmann::json& metadata() const;

  /// @brief Whether the file holds a normals graph (EncodeOptions::normals).
  bool has_normals() const;
  /// @brief The normals graph: a label file of normal codes (label_normals.hpp), read from section
  /// "normals" of this file's mapping and named "<file> (normals)" in messages. Throws
  /// FormatError when it is absent or damaged, or when its dims differ from this file's.
  std::unique_ptr<EncodedLabels> open_normals() const;

  // Whole levels, as LevelDecoder decodes them slab by slab:
  Volume decode_level0() const;  // original dtype and values, bit-exact
  // Per voxel the label of the node's largest mean weight (ties: the smaller label), source dtype.
  Volume dominant_labels(int level) const;
  // Per voxel the fraction (f32) of `label_value` (a value of the label map; Error otherwise).
  Volume label_fraction(int level, std::int64_t label_value) const;

  /// @brief Per graph node the source id of its largest mean weight (ties: the smaller id), so
  /// any voxel of any level maps to its dominant label by one lookup of its node id. Sources map
  /// to themselves. Builds the lookup on first use.
  std::vector<std::uint32_t> dominant_sources() const;
  /// @brief Per graph node the fraction of `label_value` in its mixture (the label's indicator
  /// propagated through the graph). Throws Error naming the file when the label does not occur.
  std::vector<float> label_fractions(std::int64_t label_value) const;

 private:
  friend class LevelDecoder;
  Spacing level_spacing(int level) const;

  std::unique_ptr<store::ContainerReader> reader_;
  GraphHeader header_;
  MixtureGraph graph_;
  LabelMap label_map_;
  Schedule schedule_;
  IdsMode ids_mode_ = IdsMode::blocks;
  bool ids_zstd_ = false;
  Spacing spacing_;
  Geometry geometry_;
  std::vector<Extent> level_dims_;
  std::vector<FixedRateIds> fixed_;
  std::vector<BlockPaletteIds> blocks_;
  mutable std::once_flag lookup_once_;
  mutable std::unique_ptr<MixtureLookup> lookup_;
};

/// @brief Decodes one level of an EncodedLabels in z-slabs or boxes, so a level is never held
/// whole (`strata labels decode`, the chunk endpoints of `strata serve`): level 0 the original
/// labels (bit-exact, source dtype), a coarser level the dominant label per voxel (source dtype;
/// ties: the smaller label), or with a label value that label's fraction per voxel (f32). Holds
/// only a table per graph node (the dominant source or the fraction; none for level 0).
/// `labels` must outlive it. read_box may be called from several threads at once.
class LevelDecoder final : public io::VolumeSource {
 public:
  /// @brief Throws Error naming the file for a level outside 0..level_count()-1 or a label value
  /// that does not occur.
  LevelDecoder(const EncodedLabels& labels, int level, std::optional<std::int64_t> label = {});
  /// @brief Dims, dtype, spacing (the file's, times 2^level) and placement of the decoded level.
  const VolumeInfo& info() const override { return info_; }
  const std::filesystem::path& path() const override { return labels_.path(); }
  /// @brief Slices [z0, z1) of the decoded level. Throws Error unless 0 <= z0 < z1 <= dims.z.
  Volume slices(std::int64_t z0, std::int64_t z1) const;
  /// @brief The voxels of `box` (level coordinates). Throws Error unless the box is non-empty
  /// and inside the level.
  Volume box(const Box& box) const;
  Volume read_box(const Box& b) override { return box(b); }

 private:
  const EncodedLabels& labels_;
  int level_;
  VolumeInfo info_;
  std::vector<std::uint32_t> dominant_;  // per node: its dominant source (coarser levels, no label)
  std::vector<float> fraction_;          // per node: the label's fraction (with a label)
};

}  // namespace strata::mixture
