#pragma once
// Read side of a TA-compressed .strata file: random access to any brick of any level at any
// reconstruction rank K (the rank slider), and decoding of boxes into plain volumes.
#include <filesystem>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "strata/core/volume.hpp"
#include "strata/store/container.hpp"
#include "strata/store/metadata_json.hpp"
#include "strata/ta/brick_codec.hpp"
#include "strata/ta/global_basis.hpp"
#include "strata/ta/octree.hpp"

namespace strata::ta {

class TaVolume {
 public:
  explicit TaVolume(const std::filesystem::path& path);  // throws FormatError on bad metadata
  // The same over a container already open (its index is not read again).
  explicit TaVolume(std::unique_ptr<store::ContainerReader> container);

  const store::ContainerReader& container() const { return *container_; }
  const VolumeInfo& source_info() const { return source_; }
  /// @brief Where `box` of level `level` lies in space: the source geometry moved to the centre
  /// of the box's first voxel (core/geometry.hpp level_geometry, box_geometry).
  Geometry level_geometry(int level, const Box& box) const;
  const OctreeGeometry& geometry() const { return *geometry_; }
  int rank() const { return rank_; }
  const std::string& quant_name() const { return quant_; }
  const quant::QuantScheme& quant_scheme() const { return scheme_; }
  double value_min() const { return value_lo_; }
  double value_max() const { return value_hi_; }

  /// @brief The file's codec (metadata "codec", a name of ta/codec_registry.hpp).
  const std::string& codec_name() const { return codec_name_; }
  /// @brief True for a global-basis file (codec ta-global, paper 2).
  bool global() const { return bases_ != nullptr; }
  /// @brief ta-global: the row-block bases brick `key` is rebuilt with (its factors).
  BrickBases brick_bases(const store::BrickKey& key) const;
  /// @brief ta-global: the ranks of the feature-scale table (increasing); empty otherwise.
  const std::vector<int>& feature_scale_ladder() const { return ladder_; }
  /// @brief ta-global: brick `key`'s row of the feature-scale table, the RMSE of its core
  /// region at each ladder rank (never increasing; 0 for constant bricks).
  std::span<const float> rank_errors(const store::BrickKey& key) const;

  // The index entry of `key`; throws FormatError ("brick (level l, x,y,z) is missing") when
  // the index lacks it.
  const store::BrickEntry& entry(const store::BrickKey& key) const;
  /// @brief The 64-bin histogram (store/brick_histogram.hpp) of the brick `key` and of every finer
  /// brick it covers: a coarse brick holds 2×2×2 averages, which can wash thin bright structures
  /// below a transfer function's threshold while its children keep them, so culling a subtree
  /// needs their union. Constant bricks count their value's bin (none for NaN or infinity).
  /// Throws like entry() for a key outside the octree.
  std::uint64_t subtree_histogram(const store::BrickKey& key) const;
  // Throws ParameterError("level"), naming the file, unless 0 <= level < geometry().level_count().
  void check_level(int level) const;
  // The reconstruction rank a read at `requested` uses: reconstruction_rank(requested, rank(), file).
  int reconstruction_rank(int requested) const;

  // B^3 floats of one brick (overlap included) reconstructed at rank K (clamped to 1..rank()).
  void decode_brick(const store::BrickKey& key, int k, std::span<float> out, tensor::BrickReconstructor& reconstructor,
                    DecodeScratch& scratch) const;
  // The voxels of `box` (in `level` coordinates, inside the level) as an f32 volume, decoded
  // brick by brick in parallel at rank K. Spacing is the source spacing scaled by 2^level.
  // Throws ParameterError("level") or ParameterError("box") when they are out of range.
  Volume decode_box(int level, const Box& box, int k) const;

 private:
  std::unique_ptr<store::ContainerReader> container_;
  VolumeInfo source_;
  std::unique_ptr<OctreeGeometry> geometry_;
  std::string codec_name_;
  int rank_ = 0;
  std::string quant_;
  quant::QuantScheme scheme_;
  double value_lo_ = 0, value_hi_ = 0;
  std::vector<std::vector<std::uint64_t>> subtree_histograms_;  // [level][brick index, x fastest]
  void build_subtree_histograms();
  // ta-global
  std::unique_ptr<GlobalBases> bases_;
  std::vector<int> ladder_;
  std::vector<float> feature_scale_;
  void read_global(const store::MetadataField& meta);
};

/// @brief The one rule for a reconstruction rank asked of a file that stores rank `stored` (0: a
/// file without one, a label or plain volume): 0 means the stored rank; 1..stored is taken as it
/// is. Anything else throws ParameterError("rank") naming `file` and the accepted range.
/// `decompress`, `eval` and `render` --rank, Python's read(rank=) and Renderer.frame(rank=) use it.
int reconstruction_rank(int requested, int stored, std::string_view file);

}  // namespace strata::ta
