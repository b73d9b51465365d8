#include "strata/render/label_shading.hpp"

#include <algorithm>
#include <cmath>

#include "strata/mixture/label_normals.hpp"

namespace strata::render {

LabelRgba shade_normal_code(int code, const LabelLight& light) {
  if (code <= 0 || code >= mixture::kNormalCodes) return {float(light.ambient + (1 - light.ambient) * 0.5), 0, 0, 1};
  const auto& n = mixture::normal_codebook()[std::size_t(code)];
  const double facing = std::min(1.0, std::abs(n[0] * light.towards.x + n[1] * light.towards.y + n[2] * light.towards.z));
  return {float(light.ambient + (1 - light.ambient) * facing), float(light.specular * std::pow(facing, light.shininess)), 0,
          1};
}

LabelShading::LabelShading(std::unique_ptr<mixture::EncodedLabels> normals)
    : normals_(std::move(normals)), scene_(*normals_) {}

void LabelShading::set_light(const LabelLight& light) {
  if (lit_ && light == light_) return;
  LabelColorMap map = LabelColorMap::uniform({0, 0, 0, 1});
  for (int code = 0; code < mixture::kNormalCodes; ++code) map.set(code, shade_normal_code(code, light));
  scene_.set_color_map(std::move(map));
  light_ = light;
  lit_ = true;
}

}  // namespace strata::render
