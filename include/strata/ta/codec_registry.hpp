#pragma once
/// @file
/// @brief The brick codecs `compress` writes, in one registry: their names, the parameter rules
/// they add, the payload kinds their files hold, and how they encode a brick. The CLI
/// (`--codec` and its help), `strata-mpi`, the Python module and the file readers take codec
/// names from here; `validate(const CompressParams&)` is the one check of compress parameters.
///
/// A codec serves one CodecMode: fixed-rank requests, or requests with an error target (a
/// name may have an entry for each: `ta-bricked` does). Built-in entries: ta-bricked at a fixed
/// rank (paper 1), ta-bricked to an error target (per-brick ranks and entropy-coded
/// coefficients), ta-global (paper 2's global bases). Adding a codec: one file with a
/// BrickCodec, one line in src/ta/codec_registry.cpp, its docs (docs/format.md) and tests; a
/// test may register its own with register_codec.
///
/// Thread safety: register codecs before compressing; lookups may run concurrently.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/core/progress.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/brick_codec.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/octree.hpp"
#include "strata/ta/target_codec.hpp"

namespace strata::ta {

/// @brief Which compress requests a codec entry serves.
enum class CodecMode : std::uint8_t {
  fixed_rank,    ///< CodecParams::rank and ::quant decide (no ErrorTarget)
  error_target,  ///< CodecParams::target decides each brick's ranks and precision
};
/// @brief "fixed-rank" or "error-target".
std::string_view codec_mode_name(CodecMode mode);
/// @brief The mode a request asks for: error_target when params.codec.target has a kind.
CodecMode mode_of(const CompressParams& params);

/// @brief One brick as a level of the compressor hands it to a codec.
struct BrickJob {
  int level = 0;
  std::int64_t bx = 0, by = 0, bz = 0;   ///< brick coordinates in the level's grid
  const tensor::Tensor3* samples = nullptr;  ///< B x B x B, first index fastest, all finite
  CoreRegion core;                       ///< the brick-local voxels of its core
  const BrickTarget* target = nullptr;   ///< error-target mode: this level's target; else null
  bool decoded_needed = true;            ///< a coarser level is built from the decoded samples
  /// Codecs with needs_feature_reference(), coarse levels: fills `means` (brick-sized) with the
  /// original's mean over each voxel's cell and returns the mean variance about those means
  /// (LevelPipeline::push_reference_slice). Empty otherwise.
  std::function<double(tensor::Tensor3& means)> reference;
};

class BrickCodec;

/// @brief One compress run of a codec: what it carries from brick to brick (ta-global: the
/// fitted bases and the feature-scale table).
class CodecRun {
 public:
  explicit CodecRun(const BrickCodec& codec) : codec_(codec) {}
  virtual ~CodecRun() = default;
  CodecRun(const CodecRun&) = delete;
  CodecRun& operator=(const CodecRun&) = delete;

  const BrickCodec& codec() const { return codec_; }
  /// @brief Encodes job.samples into `encoded` and leaves the decoded samples (what readers
  /// reconstruct at full rank) in `decoded`; a constant brick may skip that when
  /// !job.decoded_needed. Returns whether the brick became a constant brick. Called from
  /// worker threads concurrently, each with its own reconstructor and scratch.
  virtual bool encode(const BrickJob& job, std::vector<float>& decoded, EncodedBrick& encoded,
                      tensor::BrickReconstructor& reconstructor, DecodeScratch& scratch) const = 0;
  /// @brief After the last brick of the kept pass: adds the codec's sections to `writer` and
  /// its members to `metadata` (make_metadata's, "codec" already the codec's name), and its
  /// figures to `report`.
  virtual void finish(store::ContainerWriter& /*writer*/, nlohmann::json& /*metadata*/, CompressReport& /*report*/) const {}

 private:
  const BrickCodec& codec_;
};

/// @brief What BrickCodec::begin may use: the source is not read yet, unless the codec reads
/// it (ta-global fits its bases to the whole volume first).
struct CodecSetup {
  io::VolumeSource& source;
  const CompressParams& params;  ///< validated and normalized (BrickCodec::normalized)
  const OctreeGeometry& geometry;
  std::uint64_t slab_bytes;      ///< the input slab size the memory limit allows
  ProgressSink& progress;
};

/// @brief A brick codec: one entry of the registry.
class BrickCodec {
 public:
  virtual ~BrickCodec() = default;
  /// @brief What `--codec` takes and metadata "codec" stores ("ta-bricked").
  virtual std::string_view name() const = 0;
  virtual CodecMode mode() const = 0;
  /// @brief One line for `--help`: what the codec stores.
  virtual std::string_view summary() const = 0;
  /// @brief The payload kinds its files hold, in the order messages list them; readers
  /// refuse a brick of any other kind.
  virtual std::vector<store::PayloadKind> payload_kinds() const = 0;
  /// @brief Whether `strata-mpi compress` writes it: bricks depend only on their own samples
  /// (no whole-volume fit before the first brick).
  virtual bool distributed() const { return false; }
  /// @brief Whether bricks with NaN or infinite voxels can be stored (as `masked` payloads).
  virtual bool stores_non_finite() const { return true; }
  /// @brief Whether coarse levels need the original's per-cell means and variances
  /// (BrickJob::reference; the compressor holds them, see fixed_working_set).
  virtual bool needs_feature_reference() const { return false; }
  /// @brief The parameters as the codec uses them (ta-global stores cores only: no factor
  /// quantization). Called after validate.
  virtual CompressParams normalized(const CompressParams& params) const { return params; }
  /// @brief Rules of this codec beyond the common ones of validate(CompressParams); throws
  /// ParameterError naming the field.
  virtual void validate(const CompressParams& /*params*/) const {}
  /// @brief Starts a compress run.
  virtual std::unique_ptr<CodecRun> begin(const CodecSetup& setup) const = 0;
};

/// @brief Adds a codec. Throws Error when an entry of the same name and mode exists.
void register_codec(std::unique_ptr<BrickCodec> codec);
/// @brief Every codec, built-ins first, in registration order.
std::vector<const BrickCodec*> codecs();
/// @brief The distinct codec names, in registration order ("ta-bricked", "ta-global", ...).
std::vector<std::string> codec_names();
/// @brief The entry of `name` for `mode`; nullptr when there is none.
const BrickCodec* find_codec(std::string_view name, CodecMode mode);
/// @brief Whether some entry has this name (a .strata file with this "codec" is a TA octree).
bool is_codec_name(std::string_view name);
/// @brief The codec `params` ask for (CompressParams::codec_name in mode_of(params)). Throws
/// ParameterError("CompressParams::codec_name") for an unknown name or a mode the codec lacks.
const BrickCodec& codec_for(const CompressParams& params);
/// @brief `"a", "b" or "c"`: the codec names for messages.
std::string quoted_codec_names();

/// @brief The one check of compress parameters: the brick layout (BrickLayout::validate), the
/// codec and its mode, rank in [1, brick], hooi sweeps in [0, kMaxHooiIterations], zstd level in
/// [0, kMaxZstdLevel], the error target (check_target, and an RMSE whose square is a positive
/// double), quant and hooi left at their defaults with a target (it chooses them per brick),
/// then the codec's own rules. Throws ParameterError naming the field.
void validate(const CompressParams& params);

/// @brief Most HOOI sweeps after the truncated HOSVD.
inline constexpr int kMaxHooiIterations = 100;
/// @brief Highest zstd level of the brick payloads (the slower 20-22 need much more memory).
inline constexpr int kMaxZstdLevel = 19;
/// @brief Smallest RMSE target: below it, the square the encoder works with is no longer a
/// positive double.
inline constexpr double kMinRmseTarget = 1e-150;

}  // namespace strata::ta
