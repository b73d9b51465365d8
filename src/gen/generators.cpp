// The generator registry (names, defaults, validation) and the in-memory / streaming drivers.
#include "strata/gen/generators.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <future>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "gen/slice_generator.hpp"
#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::gen {

namespace {
constexpr std::array<std::string_view, 6> kKindNames = {"prisms", "marschner-lobb", "sphere", "voronoi", "fibres",
                                                        "superpixels"};

std::string joined_kind_names() {
  std::string all;
  for (std::string_view name : kKindNames) all += (all.empty() ? "" : ", ") + std::string(name);
  return all;
}

std::string approx_bytes(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int i = 0;
  while (bytes >= 1024 && i < 6) bytes /= 1024, ++i;
  return fmt::format("{:.3g} {}", bytes, units[i]);
}

// Slabs of ~16M voxels, 1..64 slices: bounded memory at any size (32 MB of u16 for a
// 1024x1024 slab) while each slab still has enough work for every thread.
std::int64_t stream_slab_depth(const Extent& dims) {
  const std::int64_t slice = std::max<std::int64_t>(dims.x * dims.y, 1);
  return std::clamp<std::int64_t>((std::int64_t(1) << 24) / slice, 1, 64);
}

}  // namespace

void validate(const Params& params) {
  const std::string kind(kind_name(params.kind));
  const Extent& d = params.dims;
  if (d.x <= 0 || d.y <= 0 || d.z <= 0)
    throw ParameterError("Params::dims", "generate " + kind + ": dims must be positive, got " + d.to_string());
  const double voxels = double(d.x) * double(d.y) * double(d.z);
  if (voxels > double(kMaxVoxels))
    throw ParameterError("Params::dims", fmt::format("{}: {:.3g} voxels, more than the 2^60 a volume may hold",
                                                     d.to_string(), voxels));
  const std::size_t sample = std::max(dtype_size(native_dtype(params.kind)),
                                      params.output_dtype ? dtype_size(*params.output_dtype) : std::size_t(1));
  const double slice_bytes = double(d.x) * double(d.y) * double(sample);
  if (slice_bytes > double(kMaxSliceBytes))
    throw ParameterError("Params::dims",
                         fmt::format("{}: one {}x{} slice of {}-byte samples needs {}, more than the {} a streamed "
                                     "slice may take (e.g. 8192x8192 of 4-byte samples); use smaller X and Y",
                                     d.to_string(), d.x, d.y, sample, approx_bytes(slice_bytes),
                                     approx_bytes(double(kMaxSliceBytes))));
  if (params.count < 0)
    throw ParameterError("Params::count", "generate " + kind + ": count must be >= 0, got " + std::to_string(params.count));
  // Label ids are u32, and object indices are stored in 32 bits.
  if (params.count > std::int64_t(std::numeric_limits<std::uint32_t>::max()))
    throw ParameterError("Params::count", "generate " + kind + ": count " + std::to_string(params.count) +
                                              " exceeds the u32 label range");
  const bool counts_objects = params.kind == Kind::prisms || params.kind == Kind::voronoi || params.kind == Kind::fibres;
  if (counts_objects && double(params.count) > voxels)
    throw ParameterError("Params::count", fmt::format("generate {}: count {} exceeds the {} voxels of {}", kind,
                                                      params.count, std::int64_t(voxels), d.to_string()));
  if (params.kind == Kind::superpixels && double(params.count) > double(d.x) * double(d.y))
    throw ParameterError("Params::count", fmt::format("generate superpixels: count {} exceeds the {} voxels of a "
                                                      "{}x{} section",
                                                      params.count, d.x * d.y, d.x, d.y));
  const auto setup = [&](std::int64_t count) {
    Params p = params;
    p.count = count > 0 ? count : default_count(p.kind);
    if (p.kind == Kind::prisms) return detail::prisms_setup_bytes(p);
    if (p.kind == Kind::fibres) return detail::fibres_setup_bytes(p);
    if (p.kind == Kind::voronoi) return detail::voronoi_setup_bytes(p);
    return 0.0;
  };
  const double bytes = setup(params.count);
  if (bytes > double(kMaxSetupBytes)) {
    // Blame the count when the kind's default count would fit.
    const bool count_too_large = params.count > default_count(params.kind) && setup(0) <= double(kMaxSetupBytes);
    throw ParameterError(count_too_large ? "Params::count" : "Params::dims",
                         fmt::format("generate {} {} with count {}: its objects would need about {} of memory up "
                                     "front, more than the {} allowed; use {}",
                                     kind, d.to_string(), params.count > 0 ? params.count : default_count(params.kind),
                                     approx_bytes(bytes), approx_bytes(double(kMaxSetupBytes)),
                                     count_too_large ? "a smaller count" : "smaller dims"));
  }
}

Kind parse_kind(std::string_view name) {
  for (std::size_t i = 0; i < kKindNames.size(); ++i) {
    if (name == kKindNames[i]) return Kind(i);
  }
  throw Error("unknown generator kind '" + std::string(name) + "' (expected one of: " + joined_kind_names() + ")");
}

std::string_view kind_name(Kind k) {
  const auto i = std::size_t(k);
  if (i >= kKindNames.size()) throw Error("kind_name: invalid generator kind " + std::to_string(i));
  return kKindNames[i];
}

DType native_dtype(Kind k) {
  switch (k) {
    case Kind::prisms: return DType::u16;
    case Kind::marschner_lobb:
    case Kind::sphere: return DType::f32;
    case Kind::voronoi:
    case Kind::fibres:
    case Kind::superpixels: break;
  }
  return DType::u32;
}

bool is_label_kind(Kind k) { return k == Kind::voronoi || k == Kind::fibres || k == Kind::superpixels; }

std::span<const std::string_view> kind_names() { return kKindNames; }

std::int64_t default_count(Kind k) {
  switch (k) {
    case Kind::prisms: return 40;
    case Kind::voronoi: return 64;
    case Kind::fibres: return 200;
    case Kind::superpixels: return 256;
    case Kind::marschner_lobb:
    case Kind::sphere: return 0;
  }
  return 0;
}

std::unique_ptr<Generator> make_generator(const Params& params) {
  validate(params);  // also bounds the objects the constructors below place
  Params p = params;
  if (p.count == 0) p.count = default_count(p.kind);
  switch (p.kind) {
    case Kind::prisms: return detail::make_prisms(p);
    case Kind::marschner_lobb: return detail::make_marschner_lobb(p);
    case Kind::sphere: return detail::make_sphere(p);
    case Kind::voronoi: return detail::make_voronoi(p);
    case Kind::fibres: return detail::make_fibres(p);
    case Kind::superpixels: return detail::make_superpixels(p);
  }
  throw Error("make_generator: invalid generator kind " + std::to_string(int(p.kind)));
}

namespace {

// The full range of an integer sample type.
std::pair<double, double> integer_range(DType t) {
  return visit_dtype(t, [](auto tag) -> std::pair<double, double> {
    using T = decltype(tag);
    return {double(std::numeric_limits<T>::lowest()), double(std::numeric_limits<T>::max())};
  });
}

// A slab in the output type. A scalar kind written to a narrower integer type is rescaled from
// its native type's range to the output's (prisms u16 to u8 keep their structure instead of
// saturating at 255); label ids and float outputs keep their values.
Volume to_output(Volume slab, const Params& params) {
  const DType native = native_dtype(params.kind), out = params.output_dtype.value_or(native);
  if (out == native) return slab;
  if (!is_label_kind(params.kind) && dtype_is_integer(native) && dtype_is_integer(out) &&
      dtype_size(out) < dtype_size(native)) {
    const auto [from_lo, from_hi] = integer_range(native);
    const auto [to_lo, to_hi] = integer_range(out);
    const double scale = (to_hi - to_lo) / (from_hi - from_lo);
    Volume wide = slab.converted(DType::f64);
    for (double& v : wide.samples<double>()) v = std::round(to_lo + (v - from_lo) * scale);
    return wide.converted(out);
  }
  return slab.converted(out);
}

}  // namespace

Volume generate(const Params& params) {
  auto generator = make_generator(params);
  return to_output(generator->slab(0, generator->info().dims.z), params);
}

void generate_to_file(const Params& params, const std::filesystem::path& out, ProgressSink& progress) {
  validate(params);
  // The writer first: an output format that cannot hold the volume fails before any work.
  const DType native = native_dtype(params.kind);
  VolumeInfo info{params.dims, params.output_dtype.value_or(native), {}};
  auto writer = io::create_volume_writer(out, info);
  auto generator = make_generator(params);
  if (generator->info().dtype != native) throw Error("generate: internal error: unexpected generator dtype");
  const std::int64_t depth = stream_slab_depth(info.dims);
  const auto slice_voxels = std::uint64_t(info.dims.x * info.dims.y);
  ProgressTask task(progress, "generate", std::uint64_t(info.dims.voxel_count()), "voxels");
  // Writing (and compressing) slab k overlaps computing slab k+1; at most two slabs are alive.
  std::future<void> pending;
  for (std::int64_t z0 = 0; z0 < info.dims.z; z0 += depth) {
    const std::int64_t z1 = std::min(info.dims.z, z0 + depth);
    auto slab = std::make_shared<Volume>(to_output(generator->slab(z0, z1), params));
    if (pending.valid()) pending.get();
    pending = std::async(std::launch::async, [&writer, slab] { writer->write_slab(*slab); });
    task.advance(slice_voxels * std::uint64_t(z1 - z0));
  }
  if (pending.valid()) pending.get();
  writer->finish();
}

}  // namespace strata::gen
