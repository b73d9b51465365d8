#pragma once
// The JSON metadata of a TA-compressed .strata file (docs/format.md, "Codec ta-bricked").
#include <nlohmann/json.hpp>

#include "strata/core/volume.hpp"
#include "strata/ta/compress.hpp"
#include "ta/level_pipeline.hpp"

namespace strata::ta {

// The members every TA codec writes ("codec" is params.codec_name; a codec adds its own in
// CodecRun::finish). `targets`: the per-level brick targets of an error-target file (empty in
// fixed-rank mode); `measured`: the error each level was measured to hold (error-target files).
nlohmann::json make_metadata(const VolumeInfo& source, const OctreeGeometry& geometry, const CompressParams& params,
                             const HistogramRange& range, const std::vector<BrickTarget>& targets,
                             const std::vector<LevelCounts>& measured);

}  // namespace strata::ta
