#pragma once
// The JSON metadata of a TA-compressed .strata file (docs/format.md, "Codec ta-bricked").
#include <nlohmann/json.hpp>

#include "strata/core/volume.hpp"
#include "strata/ta/compress.hpp"
#include "ta/level_pipeline.hpp"

namespace strata::ta {

nlohmann::json make_metadata(const VolumeInfo& source, const OctreeGeometry& geometry, const CompressParams& params,
                             const HistogramRange& range);

}  // namespace strata::ta
