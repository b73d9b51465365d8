#pragma once
// The JSON metadata of a TA-compressed .strata file (docs/format.md, "Codec ta-bricked").
#include <nlohmann/json.hpp>

#include "strata/core/volume.hpp"
#include "strata/ta/compress.hpp"
#include "ta/level_pipeline.hpp"

namespace strata::ta {

// `targets`: the per-level brick targets of an error-target file (empty in fixed-rank mode);
// `measured`: the error each level was measured to hold (error-target files); `global`: the
// "global" object of a ta-global file (null for ta-bricked).
nlohmann::json make_metadata(const VolumeInfo& source, const OctreeGeometry& geometry, const CompressParams& params,
                             const HistogramRange& range, const std::vector<BrickTarget>& targets,
                             const std::vector<LevelCounts>& measured, const nlohmann::json& global = nullptr);

}  // namespace strata::ta
