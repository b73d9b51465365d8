#pragma once
/// @brief Surface normals of a segmentation, quantized to a 9-bit codebook, for pre-filtered
/// label shading (paper 4, "Lighting"): the codes form a categorical volume of their own,
/// stored as a second Mixture Graph, whose leaves carry a shading value per code that the
/// graph propagates to every node of every level.
///
/// Estimation (the paper's steps, with the choices that differ stated):
/// - **Boundary band.** A voxel lies in the band when a voxel of another label is within
///   `band` voxels along every axis (the 6-neighbour boundary features, dilated).
/// - **Band normals.** In the band, the normal is the Gaussian-weighted first moment of the
///   other-label voxels in the (2 radius + 1)³ window, in world units: it points from the
///   voxel's segment towards its neighbours, outwards, and varies smoothly along a staircase
///   boundary because every window sees many steps. (The paper smooths an unsigned distance
///   transform in a band and differentiates it; the moment gives the same smooth outward field
///   without the distance transform's kink at the features, in one pass.) Outside the volume
///   counts as the voxel's own label: segments leaving the domain get no caps. Where the window
///   holds background (label 0), only background voxels count: a segmentation's visible surface
///   is where it meets the (transparent) background, and a neighbouring segment in the window
///   would tilt that normal.
/// - **Diffusion inside segments.** Voxels outside the band take the mean of their same-label
///   neighbours' normals, `diffusion` Gauss–Seidel sweeps from the band inwards; deeper voxels
///   keep code 0 ("no normal").
/// - **Vector quantization with 3D error diffusion.** Each normal, plus the error carried from
///   its already coded neighbours of the same label, takes the nearest of 511 codebook
///   directions; the residual goes on to the next voxel along x (1/2), y (1/4) and z (1/4).
#include <array>
#include <cstdint>

#include "strata/core/volume.hpp"

namespace strata::mixture {

/// @brief Codes of the normal codebook: 0 = no normal, 1..511 unit vectors.
inline constexpr int kNormalCodes = 512;

/// @brief The codebook: code 0 is the zero vector; codes 1..511 form a spherical Fibonacci
/// lattice (even coverage of the sphere, about 9° between neighbours).
const std::array<std::array<float, 3>, kNormalCodes>& normal_codebook();

/// @brief The code of the codebook direction nearest to unit vector `n`: the best of the
/// nearest codes of the 3 × 3 cells of a 128 × 128 octahedral table around n; 0 for a zero
/// vector.
std::uint16_t nearest_normal_code(const std::array<float, 3>& n);

struct NormalOptions {
  int radius = 3;        ///< window half-width in voxels, 1..4 (2: visibly bumpy on staircases; 4: twice the time)
  int band = 1;          ///< band half-width in voxels, 0..radius (0: the boundary voxels alone)
  int diffusion = 0;     ///< Gauss–Seidel sweeps into segment interiors, 0..64 (each adds distinct codes: a larger graph)
  bool error_diffusion = true;
  void validate() const;  ///< throws ParameterError("NormalOptions::…")
};

struct LabelNormals {
  Volume codes;                       ///< u16 codes, the label volume's dims and spacing
  std::uint64_t band_voxels = 0;      ///< voxels with a normal from the window moment
  std::uint64_t interior_voxels = 0;  ///< voxels with a normal from diffusion
  double seconds = 0;
};

/// @brief The unit normal estimated at every voxel of the integer label volume `labels`
/// (x fastest; the zero vector where there is none), before quantization.
std::vector<std::array<float, 3>> estimate_label_normals(const Volume& labels, const NormalOptions& options = {},
                                                         LabelNormals* counts = nullptr);

/// @brief Estimated normals quantized to codes (see above). Throws Error for a non-integer
/// dtype and ParameterError for bad options.
LabelNormals quantize_label_normals(const Volume& labels, const NormalOptions& options = {});

}  // namespace strata::mixture
