#include "ta/metadata.hpp"

namespace strata::ta {

nlohmann::json make_metadata(const VolumeInfo& source, const OctreeGeometry& geometry, const CompressParams& params,
                             const HistogramRange& range) {
  nlohmann::json levels = nlohmann::json::array();
  for (int l = 0; l < geometry.level_count(); ++l) {
    const LevelGeometry& g = geometry.level(l);
    levels.push_back({{"dims", {g.dims.x, g.dims.y, g.dims.z}}, {"bricks", {g.bricks.x, g.bricks.y, g.bricks.z}}});
  }
  return {{"codec", "ta-bricked"},
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
}

}  // namespace strata::ta
