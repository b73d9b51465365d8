// PlainSource: a plain volume file (raw, NRRD, NIfTI, TIFF) loaded whole as floats and ray cast
// as one block.
#include <cmath>

#include "render/frame_index.hpp"
#include "render/render_source_kinds.hpp"
#include "strata/render/display_defaults.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/octree.hpp"

namespace strata::render {

namespace {

Volume load_as_float(const std::filesystem::path& input, std::optional<std::int64_t> volume, DType& source_dtype) {
  io::ReadOptions read;
  read.volume = volume;
  Volume source = io::read_volume(input, read);
  source_dtype = source.dtype();
  return source.converted(DType::f32);
}

// The range of the finite samples (NaN and infinite ones are empty space); {0, 0} without any.
std::pair<double, double> sample_range(const Volume& v) {
  const auto s = v.samples<float>();
  const auto [lo, hi] = detail::finite_range(s.data(), s.size());
  if (!(lo <= hi)) return {0, 0};
  return {lo, hi};
}

}  // namespace

PlainSource::PlainSource(std::filesystem::path path, std::optional<std::int64_t> volume_index)
    : RenderSource(std::move(path)),
      volume_(load_as_float(this->path(), volume_index, source_dtype_)),
      range_(sample_range(volume_)),
      prepared_(volume_) {}

Image PlainSource::frame(const Camera& camera, const FrameSettings& settings, const std::array<float, 4>& background,
                         nlohmann::json& stats) {
  RayCaster& caster = casters_.get(frame_tf(settings), render_options(settings, background));
  RenderStats rs;
  Image image = caster.render(camera, prepared_, &rs);
  stats = stats_json(rs);
  return image;
}

// The volume box-filtered to the coarsest level at most 64 wide (as a TA file's pyramid),
// then the cells the default transfer function shows.
double PlainSource::frame_radius() const {
  const int level = frame_level(volume_.dims());
  if (level == 0) return visible_cells_radius(volume_, 0, volume_.dims(), volume_.spacing(), range_.first, range_.second);
  Volume coarse = ta::half_resolution(volume_);  // halved straight from the volume: no full-size copy
  for (int l = 1; l < level; ++l) coarse = ta::half_resolution(coarse);
  return visible_cells_radius(coarse, level, volume_.dims(), volume_.spacing(), range_.first, range_.second);
}

// Exact voxel counts; NaN and infinite voxels (empty space) are not counted.
std::vector<std::uint64_t> PlainSource::histogram() const {
  return value_histogram(volume_.samples<float>(), range_.first, range_.second);
}

Slice<float> PlainSource::value_slice(const SliceSpec& spec) {
  check_slice(spec);
  const Box box = level_slice_box(spec);
  Slice<float> out = empty_slice<float>(box, spec.axis);
  const auto v = volume_.view<float>();
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
      for (std::int64_t x = box.lo.x; x < box.hi.x; ++x) out.values[slice_offset(box, spec.axis, x, y, z)] = v(x, y, z);
  return out;
}

// A plain volume has one rank: the samples themselves.
double PlainSource::value_at(const Extent& voxel, int) {
  check_voxel(voxel);
  return volume_.view<float>()(voxel.x, voxel.y, voxel.z);
}

}  // namespace strata::render
