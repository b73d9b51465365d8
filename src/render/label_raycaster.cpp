#include "strata/core/stopwatch.hpp"
#include "strata/render/label_raycaster.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "render/traversal.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/render/sampling_limits.hpp"
#include "strata/render/transfer_function.hpp"  // Rgbaf

namespace strata::render {

namespace {

using detail::box_exit;
using detail::clip_to_box;
using detail::DividedByDirection;
using detail::for_each_pixel;
using detail::TileGrid;
using detail::unit_to_byte;

constexpr int kMaxLevels = 64;

// One mip level as the marcher sees it (read-only pointers into the LabelScene).
struct LevelView {
  const std::uint32_t* ids = nullptr;
  const std::uint8_t* occupied = nullptr;
  std::int64_t nx = 1, ny = 1, nz = 1;
  double scale = 1;  // 1 / 2^level: level-0 voxel coordinates -> this level's
  double size = 1;   // 2^level
};

// Node ids per level and the palette they index: the labels, or the normals graph's light.
struct Layer {
  std::vector<LevelView> levels;
  const float* palette = nullptr;
  bool smooth_finest = false;  // level 0 by the cubic B-spline (LabelRenderOptions::smooth)
};

// Everything a ray needs, fixed for the frame.
struct Frame {
  Layer labels;  // the label colours
  Layer light;   // normals lighting: the pre-filtered diffuse (r) and specular (g) factors
  Vec3 inv_spacing;
  Vec3 dims0;                // level-0 box in voxel coordinates
  double voxel_world = 1;    // level-0 voxel size (geometric mean of the spacing)
  lod::View view;
  LabelRenderOptions options;
  int finest = 0, top = 0;
  double ortho_lod = 0;      // orthographic: the level does not depend on depth
};

struct RayCounters {
  std::uint64_t rays = 0, samples = 0, skipped = 0, terminated = 0;
};

void validate(const LabelRenderOptions& o, int level_count) {
  check_step(o.step, "LabelRenderOptions::step");
  if (!(o.termination > 0 && o.termination <= 1))
    throw ParameterError("LabelRenderOptions::termination", fmt::format("must lie in (0, 1], got {}", o.termination));
  if (o.tile <= 0) throw ParameterError("LabelRenderOptions::tile", "must be > 0, got " + std::to_string(o.tile));
  if (o.finest_level < 0 || o.finest_level >= level_count)
    throw ParameterError("LabelRenderOptions::finest_level", std::to_string(o.finest_level) + " is not in 0.." +
                                                                 std::to_string(level_count - 1));
  if (!(std::abs(o.lod_bias) <= kMaxLevels))
    throw ParameterError("LabelRenderOptions::lod_bias",
                         fmt::format("must be a finite number of levels in [-{0}, {0}], got {1}", kMaxLevels, o.lod_bias));
  if (!(o.ambient >= 0 && o.ambient <= 1))
    throw ParameterError("LabelRenderOptions::ambient", fmt::format("must lie in 0..1, got {}", o.ambient));
  if (!(o.specular >= 0 && o.specular <= 1))
    throw ParameterError("LabelRenderOptions::specular", fmt::format("must lie in 0..1, got {}", o.specular));
  if (!(o.shininess > 0 && o.shininess <= 1024))
    throw ParameterError("LabelRenderOptions::shininess", fmt::format("must lie in (0, 1024], got {}", o.shininess));
  for (float c : {o.background.r, o.background.g, o.background.b, o.background.a})
    if (!(c >= 0 && c <= 1))
      throw ParameterError("LabelRenderOptions::background", fmt::format("components must lie in 0..1, got {}", c));
}

// floor(v) for v > -1 by truncation: the baseline x86-64 build has no inline floor, and the
// marcher's coordinates are never below -1 (they lie in the box, up to rounding).
std::int64_t floor_above_minus_one(double v) { return std::int64_t(v + 1.0) - 1; }

std::int64_t clamp_floor(double v, std::int64_t n) {
  return std::clamp<std::int64_t>(floor_above_minus_one(v), 0, n - 1);
}

// Cubic B-spline weights of the four nodes base - 1 .. base + 2 for a fraction t in [0, 1).
void bspline_weights(float t, float w[4]) {
  const float t2 = t * t, t3 = t2 * t, s = 1.0f - t;
  w[0] = s * s * s / 6.0f;
  w[1] = (3.0f * t3 - 6.0f * t2 + 4.0f) / 6.0f;
  w[2] = (-3.0f * t3 + 3.0f * t2 + 3.0f * t + 1.0f) / 6.0f;
  w[3] = t3 / 6.0f;
}

// The 4x4x4 level-0 voxels the B-spline at u weighs (voxel centres at integer + 0.5; clamped
// to the edge): their node ids and per-axis weights; `uniform` when all 64 nodes agree.
struct SplineStencil {
  std::uint32_t ids[64];
  float w[3][4];
  bool uniform = true;

  SplineStencil(const LevelView& L, const Vec3& u) {
    const double v[3] = {u.x - 0.5, u.y - 0.5, u.z - 0.5};
    const std::int64_t n[3] = {L.nx, L.ny, L.nz};
    std::int64_t at[3][4];
    for (int a = 0; a < 3; ++a) {
      const std::int64_t base = floor_above_minus_one(v[a]);
      bspline_weights(float(v[a] - double(base)), w[a]);
      for (int i = 0; i < 4; ++i) at[a][i] = std::clamp<std::int64_t>(base - 1 + i, 0, n[a] - 1);
    }
    for (int c = 0; c < 64; ++c) {
      ids[c] = L.ids[std::size_t((at[2][c >> 4] * L.ny + at[1][(c >> 2) & 3]) * L.nx + at[0][c & 3])];
      uniform = uniform && ids[c] == ids[0];
    }
  }
};

// The palette colours of the 4x4x4 level-0 voxels around u weighted by the cubic B-spline.
// Where a voxel covers several pixels (zoomed in, level 0), trilinear interpolation of a
// label's coverage draws its boundary as the voxel staircase; the B-spline is a low-pass filter
// of the same coverage with a C2-smooth boundary, at most about a voxel rounder at corners. It
// reads no voxel the trilinear sample at level 1 would not, so the skip grids still hold.
Rgbaf sample_smooth(const Layer& layer, const Vec3& u) {
  const SplineStencil st(layer.levels[0], u);
  if (st.uniform) {
    const float* p = layer.palette + std::size_t(st.ids[0]) * 4;
    return {p[0], p[1], p[2], p[3]};
  }
  Rgbaf s;
  for (int c = 0; c < 64; ++c) {
    const float weight = st.w[0][c & 3] * st.w[1][(c >> 2) & 3] * st.w[2][c >> 4];
    const float* p = layer.palette + std::size_t(st.ids[c]) * 4;
    s.r += weight * p[0];
    s.g += weight * p[1];
    s.b += weight * p[2];
    s.a += weight * p[3];
  }
  return s;
}

// Trilinear interpolation of the palette colours of the 8 voxels of level `k` around the
// level-0 voxel-space point u (voxel centres at integer + 0.5; clamp to the edge); level 0 by
// the B-spline instead when the layer asks for smooth boundaries.
Rgbaf sample_level(const Layer& layer, int k, const Vec3& u) {
  if (k == 0 && layer.smooth_finest) return sample_smooth(layer, u);
  const LevelView& L = layer.levels[std::size_t(k)];
  const double v[3] = {u.x * L.scale - 0.5, u.y * L.scale - 0.5, u.z * L.scale - 0.5};
  const std::int64_t n[3] = {L.nx, L.ny, L.nz};
  std::int64_t lo[3], hi[3];
  double w[3];
  for (int a = 0; a < 3; ++a) {
    const std::int64_t base = floor_above_minus_one(v[a]);
    w[a] = v[a] - double(base);
    lo[a] = std::clamp<std::int64_t>(base, 0, n[a] - 1);
    hi[a] = std::clamp<std::int64_t>(base + 1, 0, n[a] - 1);
  }
  std::uint32_t ids[8];
  for (int c = 0; c < 8; ++c) {
    const std::int64_t x = c & 1 ? hi[0] : lo[0], y = c & 2 ? hi[1] : lo[1], z = c & 4 ? hi[2] : lo[2];
    ids[c] = L.ids[std::size_t((z * L.ny + y) * L.nx + x)];
  }
  // Inside a uniform region all 8 nodes agree: one palette read instead of eight, no weights.
  if (std::all_of(ids + 1, ids + 8, [&](std::uint32_t id) { return id == ids[0]; })) {
    const float* p = layer.palette + std::size_t(ids[0]) * 4;
    return {p[0], p[1], p[2], p[3]};
  }
  Rgbaf s;
  for (int c = 0; c < 8; ++c) {
    const float weight = float((c & 1 ? w[0] : 1 - w[0]) * (c & 2 ? w[1] : 1 - w[1]) * (c & 4 ? w[2] : 1 - w[2]));
    const float* p = layer.palette + std::size_t(ids[c]) * 4;
    s.r += weight * p[0];
    s.g += weight * p[1];
    s.b += weight * p[2];
    s.a += weight * p[3];
  }
  return s;
}

// Level choice for a fractional LOD value: the nearest level, or (blending) the lower level
// and the weight of the next one.
struct LevelChoice {
  int level = 0;
  float next_weight = 0;
};

LevelChoice choose_level(const Frame& f, double lod) {
  if (!f.options.blend_levels) {
    const double k = std::clamp(std::floor(lod + 0.5), double(f.finest), double(f.top));
    return {int(k), 0.0f};
  }
  const double clamped = std::clamp(lod, double(f.finest), double(f.top));
  const int k = std::min(int(std::floor(clamped)), f.top);
  return {k, k == f.top ? 0.0f : float(clamped - k)};
}

Rgbaf sample(const Layer& layer, const LevelChoice& c, const Vec3& u) {
  Rgbaf s = sample_level(layer, c.level, u);
  if (c.next_weight <= 0) return s;
  const Rgbaf t = sample_level(layer, c.level + 1, u);
  const float w = c.next_weight;
  return {s.r + w * (t.r - s.r), s.g + w * (t.g - s.g), s.b + w * (t.b - s.b), s.a + w * (t.a - s.a)};
}

Rgbaf sample(const Frame& f, const LevelChoice& c, const Vec3& u) { return sample(f.labels, c, u); }

// The world-space gradient of the interpolated opacity at level `k` (central differences one
// level voxel apart).
Vec3 opacity_gradient(const Frame& f, const LevelChoice& c, const Vec3& u) {
  // A smooth level 0 is lit by level 1's gradient, two level-0 voxels either side: the
  // B-spline's own derivative still shows every voxel's bump of the surface, and six samples of
  // 64 voxels would cost more than the sample itself.
  if (c.level == 0 && c.next_weight <= 0 && f.labels.smooth_finest && f.top >= 1)
    return opacity_gradient(f, LevelChoice{1, 0.0f}, u);
  const double h = f.labels.levels[std::size_t(c.level)].size;
  double g[3];
  for (int a = 0; a < 3; ++a) {
    Vec3 step;
    (a == 0 ? step.x : a == 1 ? step.y : step.z) = h;
    g[a] = (sample(f, c, u + step).a - sample(f, c, u - step).a) / (2 * h);
  }
  // Voxel-space to world-space gradient: d/dp = d/du / spacing.
  return hadamard(Vec3{g[0], g[1], g[2]}, f.inv_spacing);
}

// Local ambient occlusion (paper 4, Fig. 7 left, after Hernell et al.): the share of light
// that reaches the sample along three short rays leaving the surface, the outward normal and
// two tilted 40° from it, each accumulating the opacity of kOcclusionSteps samples one level
// voxel apart from 1.5 voxels out. 1 in the open, less in creases and cavities.
constexpr int kOcclusionSteps = 4;

float ambient_light(const Frame& f, const LevelChoice& c, const Vec3& u, const Vec3& outward_world) {
  // The rays in voxel space: world directions scaled by 1 / spacing.
  const Vec3 n = normalized(outward_world);
  const Vec3 helper = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 t = normalized(cross(n, helper)), b = cross(n, t);
  const double tilt = std::tan(40.0 * std::numbers::pi / 180);
  const Vec3 directions[3] = {n, normalized(n + t * tilt), normalized(n - t * (0.5 * tilt) + b * (0.866 * tilt))};
  const double h = f.labels.levels[std::size_t(c.level)].size;
  double light = 0;
  for (const Vec3& d : directions) {
    const Vec3 step = hadamard(d, f.inv_spacing) * (h * f.voxel_world);  // h level-0 voxels of world length
    double through = 1;
    // From 1.5 level voxels out: the sample itself lies in its surface's one-voxel opacity ramp
    // (at a smooth level 0 the B-spline's ramp is two voxels wide: one voxel further).
    const double start = c.level == 0 && f.labels.smooth_finest ? 1.5 : 0.5;
    for (int k = 1; k <= kOcclusionSteps; ++k) through *= 1 - std::min(1.0f, sample(f, c, u + step * (k + start)).a);
    light += through;
  }
  return float(light / 3);
}

// Headlight factor from the opacity gradient, 1 where the opacity is locally flat (no
// surface); with occlusion, scaled by the ambient light that reaches the sample.
float headlight(const Frame& f, const LevelChoice& c, const Vec3& u, const Vec3& ray_direction) {
  const Vec3 world = opacity_gradient(f, c, u);
  const double norm = length(world);
  if (norm < 1e-6) return 1.0f;
  const double facing = std::abs(dot(world, ray_direction)) / norm;
  const float direct = float(f.options.ambient + (1 - f.options.ambient) * facing);
  // Opacity grows into the object: the outward normal is against the gradient.
  return f.options.occlusion ? direct * ambient_light(f, c, u, -world) : direct;
}

// The coarsest level L >= `from` whose voxel around u is empty (no visible node in its
// 3x3x3 neighbourhood), or -1. Bottom-up as in the paper: inside occupied space this costs
// one lookup; in empty space it climbs while the parent is empty too, to skip the largest
// cube.
int find_empty_cube(const Frame& f, int from, const Vec3& u, std::int64_t cube[3]) {
  int found = -1;
  for (int l = std::max(from, LabelScene::kFinestSkipLevel); l <= f.top; ++l) {
    const LevelView& L = f.labels.levels[std::size_t(l)];
    const std::int64_t x = clamp_floor(u.x * L.scale, L.nx), y = clamp_floor(u.y * L.scale, L.ny),
                       z = clamp_floor(u.z * L.scale, L.nz);
    if (L.occupied[std::size_t((z * L.ny + y) * L.nx + x)]) break;
    cube[0] = x, cube[1] = y, cube[2] = z;
    found = l;
  }
  return found;
}

// The level-of-detail value (fractional level, before clamping) for a sample at view depth
// `depth`: log2(pixel size at depth / level-0 voxel size) + lod_bias.
double label_lod(const lod::View& view, double depth, double voxel_world, double lod_bias) {
  const double pixel = view.pixel_size_at(depth);
  // A zero footprint (depth 0) means "as fine as possible"; keep it finite for the clamps.
  const double lod = pixel > 0 ? std::log2(pixel / voxel_world) : -double(kMaxLevels);
  return std::max(lod, -double(kMaxLevels)) + lod_bias;
}

double lod_at(const Frame& f, double depth) {
  return f.view.perspective ? label_lod(f.view, depth, f.voxel_world, f.options.lod_bias) : f.ortho_lod;
}

// Nearest-level choice per ray without a log2 per step: remembers the depth interval in which
// the current level stays the nearest one (lod in [k - 0.5, k + 0.5), unbounded at the
// clamped ends) and only recomputes when the depth leaves it.
class LevelTracker {
 public:
  LevelChoice at(const Frame& f, double depth) {
    if (f.options.blend_levels) return choose_level(f, lod_at(f, depth));
    if (depth >= lo_ && depth < hi_) return choice_;
    choice_ = choose_level(f, lod_at(f, depth));
    lo_ = -std::numeric_limits<double>::infinity();
    hi_ = std::numeric_limits<double>::infinity();
    if (f.view.perspective) {
      if (choice_.level > f.finest) lo_ = depth_of_lod(f, choice_.level - 0.5);
      if (choice_.level < f.top) hi_ = depth_of_lod(f, choice_.level + 0.5);
    }
    return choice_;
  }

 private:
  static double depth_of_lod(const Frame& f, double lod) {
    return f.voxel_world * std::exp2(lod - f.options.lod_bias) / f.view.pixel_angle;
  }
  double lo_ = 0, hi_ = -1;  // empty: the first call computes
  LevelChoice choice_;
};

// Front-to-back compositing along one ray; returns the premultiplied ray colour.
Rgbaf march(const Frame& f, const Ray& ray, RayCounters& counters) {
  const Vec3 o = hadamard(ray.origin, f.inv_spacing), d = hadamard(ray.direction, f.inv_spacing);
  const DividedByDirection<Vec3> param{d};
  auto [t, t_end] = clip_to_box(o, d, f.dims0, param);
  if (!(t < t_end)) return {};
  ++counters.rays;
  const double depth0 = dot(ray.origin - f.view.eye, f.view.forward), depth_rate = dot(ray.direction, f.view.forward);
  const double nudge = 1e-4 * f.voxel_world;  // crosses a cube face without skipping a voxel
  Rgbaf acc;
  LevelTracker levels;
  while (t < t_end) {
    const LevelChoice level = levels.at(f, depth0 + t * depth_rate);
    if (f.options.skip_empty) {
      std::int64_t cube[3];
      const int from = level.next_weight > 0 ? level.level + 1 : level.level;
      const int l = find_empty_cube(f, from, o + d * t, cube);
      if (l >= 0) {
        const double size = f.labels.levels[std::size_t(l)].size;
        const std::array<double, 3> lo{double(cube[0]) * size, double(cube[1]) * size, double(cube[2]) * size};
        const std::array<double, 3> hi{double(cube[0] + 1) * size, double(cube[1] + 1) * size, double(cube[2] + 1) * size};
        t = std::max(box_exit(o, d, lo, hi, param), t) + nudge;
        ++counters.skipped;
        continue;
      }
    }
    // The step grows with the level (paper §4); the last one is clipped to the box so an
    // object's total opacity does not depend on where the steps fall.
    const double dt = std::min(f.options.step * f.labels.levels[std::size_t(level.level)].size * f.voxel_world, t_end - t);
    const Vec3 at = o + d * (t + 0.5 * dt);
    Rgbaf s = sample(f, level, at);
    ++counters.samples;
    t += dt;
    if (s.a <= 1e-7f) continue;
    if (f.options.shading && f.light.palette) {
      // Pre-filtered light of the same footprint: diffuse scales the colour, specular adds
      // white in proportion to the opacity (premultiplied).
      const Rgbaf light = sample(f.light, level, at);
      s.r = s.r * light.r + s.a * light.g, s.g = s.g * light.r + s.a * light.g, s.b = s.b * light.r + s.a * light.g;
    } else if (f.options.shading) {
      const float light = headlight(f, level, at, ray.direction);
      s.r *= light, s.g *= light, s.b *= light;
    }
    // Opacity correction: label alpha is per level-0 voxel thickness.
    const double alpha = s.a >= 1 ? 1.0 : 1.0 - std::pow(1.0 - double(s.a), dt / f.voxel_world);
    const float scale = float(alpha / s.a) * (1 - acc.a);
    acc.r += scale * s.r;
    acc.g += scale * s.g;
    acc.b += scale * s.b;
    acc.a += float(alpha) * (1 - acc.a);
    if (acc.a >= f.options.termination) {
      ++counters.terminated;
      break;
    }
  }
  return acc;
}

Rgba8 over_background(const Rgbaf& c, const LabelRgba& bg) {
  const float rest = 1 - c.a;
  const float a = c.a + rest * bg.a;
  if (a <= 0) return {0, 0, 0, 0};
  // PNG stores straight alpha: un-premultiply.
  return {unit_to_byte((c.r + rest * bg.r * bg.a) / a), unit_to_byte((c.g + rest * bg.g * bg.a) / a),
          unit_to_byte((c.b + rest * bg.b * bg.a) / a), unit_to_byte(a)};
}

Frame make_frame(const LabelScene& scene, const Camera& camera, const LabelRenderOptions& options) {
  Frame f;
  const Spacing s = scene.spacing();
  f.inv_spacing = {1.0 / s.x, 1.0 / s.y, 1.0 / s.z};
  const Extent d = scene.dims();
  f.dims0 = {double(d.x), double(d.y), double(d.z)};
  f.voxel_world = std::cbrt(s.x * s.y * s.z);
  f.view = camera.view();
  f.options = options;
  f.top = scene.level_count() - 1;
  f.ortho_lod = label_lod(f.view, 1.0, f.voxel_world, options.lod_bias);
  return f;
}

// The finest level any sample of the frame can choose: the smallest footprint is at the
// nearest corner of the volume's box (depth is linear, so a corner attains the minimum).
int frame_finest_level(const Frame& f, const Spacing& s) {
  double lod = f.ortho_lod;
  if (f.view.perspective) {
    double nearest = std::numeric_limits<double>::infinity();
    for (int c = 0; c < 8; ++c) {
      const Vec3 corner{c & 1 ? f.dims0.x * s.x : 0.0, c & 2 ? f.dims0.y * s.y : 0.0, c & 4 ? f.dims0.z * s.z : 0.0};
      nearest = std::min(nearest, dot(corner - f.view.eye, f.view.forward));
    }
    lod = label_lod(f.view, std::max(nearest, 0.0), f.voxel_world, f.options.lod_bias);
  }
  const double k = f.options.blend_levels ? std::floor(lod) : std::floor(lod + 0.5);
  return int(std::clamp(k, double(f.options.finest_level), double(f.top)));
}

// The palette and levels finest..top of `scene` as the marcher reads them (skip grids with
// `skip`).
void bind_levels(const Frame& f, const LabelScene& scene, bool skip, Layer& layer) {
  layer.palette = scene.palette().data();
  layer.smooth_finest = f.options.smooth;
  std::vector<LevelView>& levels = layer.levels;
  levels.resize(std::size_t(scene.level_count()));
  for (int l = f.finest; l <= f.top; ++l) {
    LevelView& v = levels[std::size_t(l)];
    const Extent d = scene.level_dims(l);
    v.ids = scene.level_ids(l).data();
    if (skip && l >= LabelScene::kFinestSkipLevel) v.occupied = scene.occupied(l).data();
    v.nx = d.x, v.ny = d.y, v.nz = d.z;
    v.size = std::ldexp(1.0, l);
    v.scale = 1.0 / v.size;
  }
}

// One thread's share of a frame: marches pixels and counts what its rays did.
struct PixelMarcher {
  const Frame& f;
  const Camera& camera;
  Image& image;
  RayCounters counters;

  void operator()(int x, int y) {
    image.at(x, y) = over_background(march(f, camera.ray(x, y), counters), f.options.background);
  }
};

void render_tiles(const Frame& f, const Camera& camera, Image& image, LabelRenderStats& stats) {
  RayCounters total;
  for_each_pixel(
      TileGrid{image.width(), image.height(), f.options.tile}, thread_count(),
      [&] { return PixelMarcher{f, camera, image, {}}; },
      [&](const PixelMarcher& m) {
        total.rays += m.counters.rays, total.samples += m.counters.samples;
        total.skipped += m.counters.skipped, total.terminated += m.counters.terminated;
      });
  stats.rays = total.rays, stats.samples = total.samples, stats.skipped_cubes = total.skipped,
  stats.terminated_rays = total.terminated;
}

}  // namespace

Image render_labels(LabelScene& scene, const Camera& camera, const LabelRenderOptions& options,
                    LabelRenderStats* stats, LabelShading* normals) {
  const auto start = std::chrono::steady_clock::now();
  validate(options, scene.level_count());
  if (scene.level_count() > kMaxLevels) throw Error("label render: more than 64 mip levels");
  Frame f = make_frame(scene, camera, options);
  f.finest = frame_finest_level(f, scene.spacing());

  const bool lit = options.shading && options.lighting == LabelLighting::normals;
  if (lit && !normals)
    throw ParameterError("LabelRenderOptions::lighting",
                         "normals lighting needs the file's normals graph (strata labels encode --normals)");
  if (lit && normals->scene().level_count() != scene.level_count())
    throw ParameterError("LabelRenderOptions::lighting", "the normals graph's levels differ from the labels'");

  LabelPrepareReport prepared = scene.prepare(f.finest, options.skip_empty);
  bind_levels(f, scene, options.skip_empty, f.labels);
  if (lit) {
    // A headlight at infinity: towards the eye, against the view direction.
    normals->set_light({-f.view.forward, options.ambient, options.specular, options.shininess});
    const LabelPrepareReport light = normals->prepare(f.finest);
    prepared.palette_ms += light.palette_ms;
    prepared.ids_ms += light.ids_ms;
    prepared.id_voxels_decoded += light.id_voxels_decoded;
    bind_levels(f, normals->scene(), false, f.light);
  }

  LabelRenderStats local;
  local.palette_ms = prepared.palette_ms;
  local.ids_ms = prepared.ids_ms;
  local.skip_grid_ms = prepared.skip_ms;
  local.ids_decoded = prepared.id_voxels_decoded;
  local.finest_level = f.finest;
  local.coarsest_level = f.top;

  Image image(camera.width(), camera.height());
  const auto march_start = std::chrono::steady_clock::now();
  render_tiles(f, camera, image, local);
  local.march_ms = ms_since(march_start);
  local.ms = ms_since(start);
  if (stats) *stats = local;
  return image;
}

nlohmann::json stats_json(const LabelRenderStats& s) {
  nlohmann::json j;
  j["render"] = {{"ms", s.ms},
                 {"march_ms", s.march_ms},
                 {"palette_ms", s.palette_ms},
                 {"ids_ms", s.ids_ms},
                 {"skip_grid_ms", s.skip_grid_ms},
                 {"ids_decoded", s.ids_decoded},
                 {"rays", s.rays},
                 {"samples", s.samples},
                 {"skipped_cubes", s.skipped_cubes},
                 {"terminated_rays", s.terminated_rays},
                 {"levels", {s.finest_level, s.coarsest_level}}};
  return j;
}

}  // namespace strata::render
