#pragma once
// Steps of compress_volume that the distributed driver (src/dist) runs on its part of a volume:
// they are shared so that both make the same bytes.
#include <filesystem>
#include <limits>

#include "strata/core/volume.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/compress.hpp"
#include "ta/level_pipeline.hpp"

namespace strata::ta {

class StepCalibrator;

// The finite value range of a volume, slab by slab: widen() with each slab (and the level-0
// spectrum into `calibrator` when there is one, slices in z order), range() at the end.
struct RangeScan {
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  void widen(const Volume& slab, StepCalibrator* calibrator = nullptr);
  // {0, 0} when no sample was finite (every brick is a constant NaN or infinity).
  HistogramRange range() const { return lo <= hi ? HistogramRange{lo, hi} : HistogramRange{0, 0}; }
};

// Throws Error (naming `file`) for a range the codec cannot hold in `params`' mode.
void check_codable(const HistogramRange& range, const std::filesystem::path& file, const CompressParams& params);

// Converts each slice of `slab` to floats and pushes it to `level0`.
void push_slab_to_level0(const Volume& slab, LevelPipeline& level0);

// The index entry of an encoded brick (offset, size and checksum are filled by the writer).
store::BrickEntry index_entry(const store::BrickKey& key, const EncodedBrick& brick, float lo, float hi,
                              std::uint64_t histogram);

// Adds an encoded brick to the report's per-level counts and byte totals.
void count_brick(CompressReport& report, const store::BrickKey& key, const EncodedBrick& brick);

}  // namespace strata::ta
