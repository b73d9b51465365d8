#pragma once
/// @file
/// @brief Deterministic synthetic volumes (scalar and label kinds) evaluated slab by slab, so any
/// size streams to disk: what `strata generate`, the tests and the benchmarks use.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string_view>

#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"

namespace strata::gen {

/// @brief Synthetic volumes. Every generator is deterministic for a seed and evaluates any slab
/// independently, so volumes of any size stream to disk slab by slab.
enum class Kind {
  prisms,          // scalar: smooth blobs + thin curved fibre bundles + noise (enamel-like), u16
  marschner_lobb,  // scalar: the Marschner–Lobb test signal in [-1,1]^3, f32 in [0,1]
  sphere,          // scalar: analytic solid sphere (value 1 inside, smooth 1-voxel edge), f32
  voronoi,         // labels: N warped Voronoi cells separated by thin background membranes, u32
  fibres,          // labels: N curved tubes on ~85% background, u32
  superpixels,     // labels: ~N 2D superpixels per z-section, own ids per section, sections in runs
                   // sharing one partition (serial-section EM over-segmentation), no background, u32
};

/// @brief The kind of a name as kind_name spells it; throws Error naming the valid ones otherwise.
Kind parse_kind(std::string_view name);  // "prisms", "marschner-lobb", "sphere", "voronoi", "fibres", "superpixels"
std::string_view kind_name(Kind k);
bool is_label_kind(Kind k);
DType native_dtype(Kind k);  // the sample type a kind computes: u16 prisms, f32 analytic, u32 labels
std::span<const std::string_view> kind_names();  // every valid name, in Kind order
/// @brief What count = 0 means: prisms 40 blobs (plus max(3, count/4) fibre bundles), voronoi 64 cells,
/// fibres 200 tubes, superpixels 256 per section; marschner-lobb ignores count; sphere uses count
/// as its radius in voxels when > 0 (default 0.4 * the smallest dimension).
std::int64_t default_count(Kind k);

/// @brief What to generate: kind, dims, seed, object count and output sample type.
struct Params {
  Kind kind = Kind::prisms;
  Extent dims{64, 64, 64};
  std::uint64_t seed = 1;
  std::int64_t count = 0;  // number of blobs/fibres/cells; 0 = the kind's default
  // Sample type of the written file; unset = the kind's own. Values are converted (rounded and
  // clamped for integer targets), e.g. prisms as f32 for float-pipeline tests.
  std::optional<DType> output_dtype;
};

/// @brief One configured generator (make_generator): its volume's header and any slab of it.
class Generator {
 public:
  virtual ~Generator() = default;
  virtual const VolumeInfo& info() const = 0;
  /// @brief Slices [z0, z1); thread-safe and deterministic (same bytes for any slab partition).
  virtual Volume slab(std::int64_t z0, std::int64_t z1) const = 0;
};

/// What any size may cost. Slabs are streamed, so memory does not grow with the depth; it is
/// bounded by the slabs in flight (about 16M voxels each, at least one slice) and by the objects
/// a kind places up front (blob lists, tube segments, Voronoi sites and their z-index).
inline constexpr std::uint64_t kMaxSliceBytes = std::uint64_t(256) << 20;  // one X*Y slice, widest dtype
inline constexpr std::uint64_t kMaxSetupBytes = std::uint64_t(2) << 30;   // objects placed up front
inline constexpr std::int64_t kMaxVoxels = std::int64_t(1) << 60;          // product of the dims

/// @brief Throws ParameterError("Params::dims") unless every dimension is positive, their product is at
/// most kMaxVoxels and one slice holds at most kMaxSliceBytes of samples (of the kind's own dtype
/// and output_dtype), and ParameterError("Params::count") when count is negative, exceeds the
/// voxels (a slice's voxels for superpixels) or the u32 label range; either one when the objects
/// the kind places up front would need more than kMaxSetupBytes (an estimate, from dims and count).
/// Runs in constant time: nothing is allocated.
void validate(const Params& params);

/// @brief The generator of `params`. Throws as validate().
std::unique_ptr<Generator> make_generator(const Params& params);
Volume generate(const Params& params);  // whole volume in memory (small sizes)
/// @brief Streams the volume to any format io can write, slab by slab, with progress. The output file
/// is created (and its format's limits checked) before any object is placed.
void generate_to_file(const Params& params, const std::filesystem::path& out, ProgressSink& progress);

}  // namespace strata::gen
