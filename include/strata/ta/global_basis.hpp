#pragma once
/// @file
/// @brief Global Tucker bases of a whole volume (paper 2, TAMRESH §3–4.1): one set of factor
/// matrices U(n) (I_n × R) for the volume, fitted by HOOI streaming the volume slab by slab
/// (never loaded whole), their mipmaps (pairwise row averages, one per octree level), and the
/// orthonormal row-block bases a brick of a level is projected onto (Fig. 10). The global-basis
/// codec builds its per-brick cores on these.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "strata/ta/codec_names.hpp"
#include "strata/core/extent.hpp"
#include "strata/core/progress.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/octree.hpp"
#include "strata/tensor/tensor3.hpp"

namespace strata::ta {

/// How the HOOI starts. The paper starts from random matrices; the leading DCT-II vectors
/// (smooth cosines, what the leading singular vectors of a smooth volume resemble) need no
/// pass over the data and are deterministic without a seed.
enum class GlobalInit { dct, random };


struct GlobalFitOptions {
  int rank = 16;                               ///< R per mode (clamped to each extent); paper: half the brick width
  int max_sweeps = 3;                          ///< HOOI sweeps (three passes over the volume each)
  double tolerance = 1e-4;                     ///< stop once a sweep improves the fit by less
  std::uint64_t slab_bytes = 64ull << 20;      ///< float samples read per step (at least one slice)
  GlobalInit init = GlobalInit::dct;
  std::uint64_t seed = 1;                      ///< for GlobalInit::random
};

struct GlobalFit {
  tensor::Factors<double> factors;   ///< U(n), I_n × R_n, orthonormal columns
  std::vector<double> fit_per_sweep;  ///< 1 − ‖A − Ã‖F / ‖A‖F after each sweep (never decreases)
  std::int64_t passes = 0;            ///< reads of the whole volume
  double seconds = 0;
  double fit() const { return fit_per_sweep.empty() ? 0.0 : fit_per_sweep.back(); }
};

/// @brief Fits global factor matrices to `source` by HOOI (Alg. 1): each mode's update projects
/// the volume on the other two factors, accumulating slab by slab, and takes the projection's
/// leading left singular vectors (thin SVD: no I_n × I_n Gram matrix). Non-finite voxels count
/// as 0. Memory: one slab of options.slab_bytes plus O(I_n · R²) per mode. Throws ParameterError("GlobalFitOptions::…")
/// for a rank < 1, max_sweeps < 1 or a negative tolerance.
GlobalFit fit_global_factors(io::VolumeSource& source, const GlobalFitOptions& options, ProgressSink& progress);

/// @brief The next coarser level's factor (§3.1.2): row i is the mean of rows 2i and 2i+1; an
/// odd last row is kept alone (the octree's odd extents round up, repeating the edge voxel).
/// A model reconstructed with halved factors is exactly the 2×2×2 average of the original's.
tensor::Matrix<double> halve_rows(const tensor::Matrix<double>& factor);

/// @brief Factor `factor` halved `levels − 1` times: element l belongs to octree level l.
std::vector<tensor::Matrix<double>> mipmap_factor(const tensor::Matrix<double>& factor, int levels);

/// @brief The orthonormal basis of a brick's rows (Fig. 10): rows first_row … first_row +
/// rows − 1 of a level's factor (rows outside the level clamped to its edge, as the octree
/// clamps samples), re-spanned by a thin SVD. Its min(rows, R) columns span the same space as
/// the row block, ordered by decreasing singular value so that leading-rank truncation keeps
/// the strongest directions; each column's largest-magnitude entry is positive.
tensor::Matrix<double> row_block_basis(const tensor::Matrix<double>& level_factor, std::int64_t first_row, int rows);

/// @brief The row-block bases of every brick position of every octree level (Fig. 10): for
/// level l and mode n, one basis per brick index along that mode, from the factor mipmapped to
/// level l, over the brick's sample rows (overlap included), B × min(B, R_n) floats.
class GlobalBases {
 public:
  GlobalBases(const tensor::Factors<double>& factors, const OctreeGeometry& geometry);

  /// @brief The basis of mode `mode` (1..3) for bricks at index `index` along it on `level`.
  const tensor::Matrix<float>& basis(int level, int mode, std::int64_t index) const;
  /// @brief The three bases of brick (bx, by, bz) of `level`, for modes 1, 2, 3.
  std::array<const tensor::Matrix<float>*, 3> brick_bases(int level, std::int64_t bx, std::int64_t by, std::int64_t bz) const;
  /// @brief Columns of every basis of mode `mode` (1..3): min(R_n, B).
  int rank(int mode) const { return ranks_[std::size_t(mode - 1)]; }

  /// @brief The bytes of section `global_bases` (docs/format.md): every basis as B × rank(n)
  /// little-endian f32, column-major, in the order level, mode, brick index.
  std::vector<std::byte> serialize() const;
  /// @brief Bases read from those bytes for `geometry` and `ranks` columns per mode. Throws
  /// FormatError(file, "section global_bases", …) when the size does not match or a value is
  /// not finite.
  static GlobalBases deserialize(std::span<const std::byte> bytes, const OctreeGeometry& geometry,
                                 const std::array<int, 3>& ranks, const std::string& file);

 private:
  GlobalBases() = default;
  std::array<int, 3> ranks_{};
  // bases_[level][mode - 1][index]
  std::vector<std::array<std::vector<tensor::Matrix<float>>, 3>> bases_;
};

/// @brief A brick's core tensor (§4.2): its samples (B × B × B, overlap included) projected on
/// its three row-block bases, samples ×1 Q1ᵀ ×2 Q2ᵀ ×3 Q3ᵀ.
tensor::Tensor3 project_brick(const tensor::Tensor3& samples, const std::array<const tensor::Matrix<float>*, 3>& bases);

/// @brief A brick's row of the feature-scale table (§4.2): for each rank K of `ladder`
/// (increasing, each ≥ 1), the RMSE over `region` (brick-local voxels: the brick's core, the
/// borders excluded) of the brick rebuilt from the leading K × K × K block of `core` (ranks
/// clamped to the core's). The projections on nested subspaces never lose accuracy over the
/// whole brick, but over a part of it a higher rank may be slightly worse; each entry is
/// therefore the largest RMSE of its rank and every higher one, so a renderer that picks the
/// lowest rank meeting a target never gets more error than the table says.
///
/// Coarse levels are measured against the original: `reference` holds, at the region's voxels,
/// the original's mean over each voxel's cell and `resolution_variance` the mean over the region
/// of the original's variance within a cell. Upsampled cell by cell (nearest), the brick's
/// squared error against the original is then exactly variance + (mean − rebuilt)² per cell, so
/// each entry is sqrt(MSE against the means + resolution_variance). At level 0 the reference is
/// the samples and the variance 0.
std::vector<double> rank_ladder_rmse(const tensor::Tensor3& reference, const tensor::Tensor3& core,
                                     const std::array<const tensor::Matrix<float>*, 3>& bases, const Box& region,
                                     const std::vector<int>& ladder, double resolution_variance = 0);

}  // namespace strata::ta
