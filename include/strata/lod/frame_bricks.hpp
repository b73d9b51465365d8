#pragma once
/// @file
/// @brief The contract between level-of-detail management (lod) and the ray caster (render): the set
/// of reconstructed bricks a frame may sample. A brick's samples are the B^3 floats that
/// ta::TaVolume::decode_brick produces (x fastest, overlap included), so a sampler at level-l
/// position q (level-l voxel units, voxel centres at j + 0.5) reads local index
/// q - 0.5 - core_origin + overlap with trilinear interpolation and central differences inside
/// the stored overlap.
#include <cstdint>
#include <memory>
#include <vector>

#include "strata/store/container.hpp"

namespace strata::lod {

/// @brief One reconstructed brick a frame may sample, or a constant brick's value.
struct ResidentBrick {
  store::BrickKey key;
  int rank = 0;                                        // reconstruction rank K of `samples`
  std::shared_ptr<const std::vector<float>> samples;   // B^3 floats; empty for constant bricks
  float constant_value = 0;                            // the value of every voxel when samples is empty
  bool is_constant() const { return !samples; }
};

/// @brief Per-frame loader figures (paper 1, Figs. 4-5 breakdown).
struct LoadStats {
  std::uint64_t selected = 0;     // bricks in the LOD cut
  std::uint64_t resident = 0;     // bricks handed to the renderer (cut bricks or stand-in ancestors)
  std::uint64_t cache_hits = 0, cache_misses = 0;
  std::uint64_t bytes_read = 0;   // compressed payload bytes fetched from the file this frame
  double decode_ms = 0;           // dequantisation + reconstruction time spent waiting in this frame
  std::uint64_t pending = 0;      // misses still queued for the loader threads
};

/// @brief Bricks that together cover every non-empty region of the cut: each cut brick itself when
/// resident, otherwise its nearest resident ancestor (progressive refinement). Regions whose
/// bricks are empty under the transfer function are simply absent.
struct FrameBricks {
  std::vector<ResidentBrick> bricks;
  LoadStats stats;
};

}  // namespace strata::lod
