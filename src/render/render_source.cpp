// RenderSource: the defaults and argument checks every kind shares, the table of openers, and
// what the kinds share for frames (the ray caster slot, the default camera's framing).
#include "render/render_source.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "render/render_source_kinds.hpp"
#include "strata/core/error.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/store/brick_histogram.hpp"
#include "strata/store/container.hpp"
#include "strata/store/volume_set.hpp"
#include "strata/ta/octree.hpp"

namespace strata::render {

// ---- RenderSource -----------------------------------------------------------------------------

RenderSource::RenderSource(std::filesystem::path path) : path_(std::move(path)) {}
RenderSource::~RenderSource() = default;

void RenderSource::check_slice(const SliceSpec& spec) const {
  if (spec.level < 0 || spec.level >= level_count())
    throw ParameterError("SliceSpec::level", "level " + std::to_string(spec.level) + " is not in 0.." +
                                                 std::to_string(level_count() - 1));
  (void)slice_box(level_dims(0), spec.axis, spec.index);  // the level-0 index must lie inside
}

void RenderSource::check_voxel(const Extent& v) const {
  const Extent dims = level_dims(0);
  if (v.x < 0 || v.y < 0 || v.z < 0 || v.x >= dims.x || v.y >= dims.y || v.z >= dims.z)
    throw ParameterError("voxel", "voxel " + v.to_string() + " is outside the volume " + dims.to_string());
}

Box RenderSource::level_slice_box(const SliceSpec& spec) const {
  return slice_box(level_dims(spec.level), spec.axis, spec.index >> spec.level);
}

void RenderSource::not_labels() const {
  throw Error(path_.string() + ": not a label volume (this is a " + std::string(dataset_kind_name(kind())) + " volume)");
}

Slice<std::int64_t> RenderSource::label_slice(const SliceSpec&) { not_labels(); }
Slice<float> RenderSource::label_fraction_slice(const SliceSpec&, std::int64_t) { not_labels(); }
Image RenderSource::palette_slice(const SliceSpec&) { not_labels(); }
std::int64_t RenderSource::label_at(const Extent&) const { not_labels(); }
double RenderSource::set_label_colors(LabelColorMap) { not_labels(); }
const mixture::EncodedLabels& RenderSource::labels() const { not_labels(); }

// ---- Opening ------------------------------------------------------------------------------------

SourceFile::SourceFile(std::filesystem::path path, std::optional<std::int64_t> volume)
    : path_(std::move(path)), volume_(volume) {}
SourceFile::~SourceFile() = default;

bool SourceFile::is_container() {
  if (!is_container_) is_container_ = store::is_strata_file(path_);
  return *is_container_;
}

store::ContainerReader& SourceFile::container() {
  if (!container_) container_ = store::open_volume(path_, volume_);
  return *container_;
}

std::string SourceFile::codec() { return container().metadata().value("codec", std::string()); }

std::unique_ptr<store::ContainerReader> SourceFile::take_container() {
  container();
  return std::move(container_);
}

namespace {

// The openers' table. Order matters: the catch-all for .strata files comes last.
constexpr std::array kOpeners{
    SourceOpener{"plain", [](SourceFile& f) { return !f.is_container(); },
                 [](SourceFile& f, const SessionOptions&) -> std::unique_ptr<RenderSource> {
                   return std::make_unique<PlainSource>(f.path(), f.volume());
                 }},
    SourceOpener{"labels", [](SourceFile& f) { return f.is_container() && f.codec() == mixture::kMixtureCodecName; },
                 [](SourceFile& f, const SessionOptions&) -> std::unique_ptr<RenderSource> {
                   return std::make_unique<LabelSource>(f.path(), f.take_container());
                 }},
    SourceOpener{"scalar", [](SourceFile& f) { return f.is_container(); },
                 [](SourceFile& f, const SessionOptions& options) -> std::unique_ptr<RenderSource> {
                   return std::make_unique<TaSource>(f.path(), f.take_container(), options);
                 }},
};

}  // namespace

std::span<const SourceOpener> source_openers() { return kOpeners; }

std::unique_ptr<RenderSource> open_render_source(const std::filesystem::path& path, const SessionOptions& options) {
  SourceFile file(path, options.volume);
  for (const SourceOpener& opener : source_openers())
    if (opener.accepts(file)) return opener.open(file, options);
  throw Error(path.string() + ": no renderer reads this kind of file");
}

// ---- Shared by the kinds ------------------------------------------------------------------------

RenderOptions render_options(const FrameSettings& s, const std::array<float, 4>& background) {
  RenderOptions o;
  o.step = s.step;
  o.shading = s.shading;
  o.jitter = s.jitter;
  o.jitter_pass = s.pass;
  o.background = background;
  return o;
}

const TransferFunction& frame_tf(const FrameSettings& settings) {
  static const TransferFunction ct = TransferFunction::preset("ct");
  return settings.tf ? *settings.tf : ct;
}

RayCaster& CasterSlot::get(const TransferFunction& tf, const RenderOptions& options) {
  std::string key = fmt::format("{}|{}|{}|{}", tf.to_json().dump(), options.step, options.shading, options.jitter);
  if (!caster_ || key != key_) {
    caster_ = std::make_unique<RayCaster>(tf, options);
    key_ = std::move(key);
  }
  caster_->set_jitter_pass(options.jitter_pass);
  return *caster_;
}

FrameSphere::FrameSphere(const Extent& dims, const Spacing& spacing)
    : centre{0.5 * double(dims.x) * spacing.x, 0.5 * double(dims.y) * spacing.y, 0.5 * double(dims.z) * spacing.z},
      bounding(length(centre)) {}

void FrameSphere::add_box(const Vec3& lo, const Vec3& hi) {
  const Vec3 far{std::max(std::abs(lo.x - centre.x), std::abs(hi.x - centre.x)),
                 std::max(std::abs(lo.y - centre.y), std::abs(hi.y - centre.y)),
                 std::max(std::abs(lo.z - centre.z), std::abs(hi.z - centre.z))};
  radius = std::max(radius, length(far));
}

void FrameSphere::add_cell(const Extent& dims0, const Spacing& s, int level, std::int64_t x, std::int64_t y,
                           std::int64_t z) {
  const double cell = std::ldexp(1.0, level);
  add_box({double(x) * cell * s.x, double(y) * cell * s.y, double(z) * cell * s.z},
          {std::min(double(x + 1) * cell, double(dims0.x)) * s.x, std::min(double(y + 1) * cell, double(dims0.y)) * s.y,
           std::min(double(z + 1) * cell, double(dims0.z)) * s.z});
}

double FrameSphere::rounded() const {
  if (radius <= 0) return 0;
  const double step = bounding / kSteps;
  return std::min(bounding, std::ceil(radius / step) * step);
}

int frame_level(Extent dims) {
  int level = 0;
  while (std::max({dims.x, dims.y, dims.z}) > FrameSphere::kWidest) {
    dims = ta::half_extent(dims);
    ++level;
  }
  return level;
}

double visible_cells_radius(const Volume& coarse, int level, const Extent& dims0, const Spacing& s, double lo, double hi) {
  FrameSphere sphere(dims0, s);
  const std::uint64_t bins = frame_tf(FrameSettings{}).visible_bins(lo, hi);
  const store::HistogramBinning binning(lo, hi);
  const auto v = coarse.view<float>();
  const Extent d = coarse.dims();
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const float f = v(x, y, z);
        if (std::isfinite(f) && ((bins >> binning.bin(f)) & 1u)) sphere.add_cell(dims0, s, level, x, y, z);
      }
  return sphere.rounded();
}

}  // namespace strata::render
