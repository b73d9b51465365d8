#include "ta/metadata.hpp"

#include <cmath>

#include "strata/store/geometry_json.hpp"

namespace strata::ta {

namespace {

// What each level holds, so a reader can tell its error without the source.
// Bounds ("rmse": every brick's cap, "max_error": every voxel's) where the encoder guarantees
// them per brick, and the error measured over the whole level.
nlohmann::json target_metadata(const ErrorTarget& target, const std::vector<BrickTarget>& targets,
                               const std::vector<LevelCounts>& measured) {
  nlohmann::json levels = nlohmann::json::array();
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const BrickTarget& t = targets[i];
    nlohmann::json l{{"core_step", t.core_step}};
    if (std::isfinite(t.mse_cap)) l["rmse"] = std::sqrt(t.mse_cap);
    if (std::isfinite(t.max_error)) l["max_error"] = t.max_error;
    if (i < measured.size()) {
      l["measured_rmse"] = measured[i].rmse;
      l["measured_max_error"] = measured[i].max_error;
    }
    levels.push_back(l);
  }
  return {{"kind", target_kind_name(target.kind)},
          {"value", target.value},
          {"coarse_growth", target.coarse_growth},
          {"levels", levels}};
}

}  // namespace

nlohmann::json make_metadata(const VolumeInfo& source, const OctreeGeometry& geometry, const CompressParams& params,
                             const HistogramRange& range, const std::vector<BrickTarget>& targets,
                             const std::vector<LevelCounts>& measured) {
  nlohmann::json levels = nlohmann::json::array();
  for (int l = 0; l < geometry.level_count(); ++l) {
    const LevelGeometry& g = geometry.level(l);
    levels.push_back({{"dims", {g.dims.x, g.dims.y, g.dims.z}}, {"bricks", {g.bricks.x, g.bricks.y, g.bricks.z}}});
  }
  nlohmann::json m = {{"codec", params.codec_name},
                      {"codec_version", 1},
                      {"source",
                       {{"dims", {source.dims.x, source.dims.y, source.dims.z}},
                        {"spacing", {source.spacing.x, source.spacing.y, source.spacing.z}},
                        {"dtype", std::string(dtype_name(source.dtype))},
                        {"value_range", {range.lo, range.hi}}}},
                      {"brick", params.layout.brick},
                      {"overlap", params.layout.overlap},
                      {"rank", params.codec.rank},
                      {"quant", params.codec.quant.to_string()},
                      {"hooi_iterations", params.codec.hooi_iterations},
                      {"zstd_level", params.codec.zstd_level},
                      {"levels", levels}};
  if (!source.geometry.is_default()) m["source"]["geometry"] = store::geometry_to_json(source.geometry);
  if (!targets.empty()) {
    // Error-target bricks carry their own steps; no fixed quantization scheme applies.
    m["quant"] = kCodedQuantName;
    m.erase("hooi_iterations");
    m["target"] = target_metadata(params.codec.target, targets, measured);
  }
  return m;
}

}  // namespace strata::ta
