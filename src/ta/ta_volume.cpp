#include "strata/ta/ta_volume.hpp"

#include <algorithm>
#include <cmath>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/ta/target_codec.hpp"

namespace strata::ta {

namespace {

// `prefix` is the path of `j` inside the metadata ("metadata" or "metadata.source"), so every
// message names the full field.
template <class T>
T required(const nlohmann::json& j, const char* key, const std::string& file, const std::string& prefix = "metadata") {
  const std::string field = prefix + "." + key;
  if (!j.is_object() || !j.contains(key)) throw FormatError(file, field, "missing");
  try {
    return j.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw FormatError(file, field, "has the wrong type");
  }
}

Extent positive_extent(const std::vector<std::int64_t>& v, const std::string& file, const char* field) {
  if (v.size() != 3 || v[0] < 1 || v[1] < 1 || v[2] < 1)
    throw FormatError(file, field, "expected three positive extents [x, y, z]");
  return {v[0], v[1], v[2]};
}

}  // namespace

TaVolume::TaVolume(const std::filesystem::path& path) : TaVolume(std::make_unique<store::ContainerReader>(path)) {}

TaVolume::TaVolume(std::unique_ptr<store::ContainerReader> container) : container_(std::move(container)) {
  const std::string file = container_->path().string();
  const nlohmann::json& m = container_->metadata();
  if (!m.contains("codec") || !m["codec"].is_string() || m["codec"] != "ta-bricked")
    throw FormatError(file, "metadata.codec",
                      "expected \"ta-bricked\", found " + (m.contains("codec") ? m["codec"].dump() : std::string("none")));
  const nlohmann::json source = required<nlohmann::json>(m, "source", file);
  const std::string src = "metadata.source";
  source_.dims = positive_extent(required<std::vector<std::int64_t>>(source, "dims", file, src), file, "metadata.source.dims");
  try {
    source_.dtype = parse_dtype(required<std::string>(source, "dtype", file, src));
  } catch (const FormatError&) {
    throw;
  } catch (const Error& e) {
    throw FormatError(file, "metadata.source.dtype", e.what());
  }
  const auto spacing = required<std::vector<double>>(source, "spacing", file, src);
  if (spacing.size() != 3) throw FormatError(file, "metadata.source.spacing", "expected 3 values");
  source_.spacing = {spacing[0], spacing[1], spacing[2]};
  const auto range = required<std::vector<double>>(source, "value_range", file, src);
  if (range.size() != 2) throw FormatError(file, "metadata.source.value_range", "expected [min, max]");
  value_lo_ = range[0];
  value_hi_ = range[1];
  BrickLayout layout{required<int>(m, "brick", file), required<int>(m, "overlap", file)};
  try {
    geometry_ = std::make_unique<OctreeGeometry>(source_.dims, layout);
  } catch (const Error& e) {
    throw FormatError(file, "metadata.brick", e.what());
  }
  rank_ = required<int>(m, "rank", file);
  if (rank_ < 1 || rank_ > layout.brick) throw FormatError(file, "metadata.rank", "out of range 1..brick width");
  quant_ = required<std::string>(m, "quant", file);
  try {
    // Error-target files code every brick with its own steps; the default scheme is never used.
    if (quant_ != kCodedQuantName) scheme_ = quant::QuantScheme::parse(quant_);
  } catch (const Error& e) {
    throw FormatError(file, "metadata.quant", e.what());
  }
  const auto levels = required<nlohmann::json>(m, "levels", file);
  if (!levels.is_array() || int(levels.size()) != geometry_->level_count())
    throw FormatError(file, "metadata.levels",
                      "expected " + std::to_string(geometry_->level_count()) + " levels for these dims and brick size");
}

const store::BrickEntry& TaVolume::entry(const store::BrickKey& key) const {
  const store::BrickEntry* e = container_->find(key);
  if (!e) throw FormatError(container_->path().string(), "index", store::brick_name(key) + " is missing");
  return *e;
}

void TaVolume::decode_brick(const store::BrickKey& key, int k, std::span<float> out, tensor::BrickReconstructor& reconstructor,
                            DecodeScratch& scratch) const {
  const store::BrickEntry& e = entry(key);
  ta::decode_brick(e.kind, container_->payload(e), e.min, scheme_, geometry_->layout().brick,
                   std::clamp(k, 1, rank_), reconstructor, scratch, out, container_->path().string());
}

void TaVolume::check_level(int level) const {
  if (level < 0 || level >= geometry_->level_count())
    throw ParameterError("level", std::to_string(level) + " is not in 0.." + std::to_string(geometry_->level_count() - 1) +
                                      " for " + container_->path().string());
}

Volume TaVolume::decode_box(int level, const Box& box, int k) const {
  check_level(level);
  const LevelGeometry& g = geometry_->level(level);
  if (box.empty() || !Box::whole(g.dims).contains(box))
    throw ParameterError("box", box.to_string() + " is not inside level " + std::to_string(level) + " (" +
                                    g.dims.to_string() + ")");
  const double scale = std::ldexp(1.0, level);
  Volume out(box.size(), DType::f32, {source_.spacing.x * scale, source_.spacing.y * scale, source_.spacing.z * scale});
  const BrickLayout& l = geometry_->layout();
  const std::int64_t c = l.core();
  const Extent lo_brick{box.lo.x / c, box.lo.y / c, box.lo.z / c};
  const Extent hi_brick{(box.hi.x - 1) / c + 1, (box.hi.y - 1) / c + 1, (box.hi.z - 1) / c + 1};
  const Extent n{hi_brick.x - lo_brick.x, hi_brick.y - lo_brick.y, hi_brick.z - lo_brick.z};
  auto view = out.view<float>();
  std::exception_ptr failure;
#pragma omp parallel num_threads(thread_count())
  {
    tensor::BrickReconstructor reconstructor;
    DecodeScratch scratch;
    std::vector<float> brick(std::size_t(l.brick) * l.brick * l.brick);
#pragma omp for schedule(dynamic)
    for (std::int64_t i = 0; i < n.voxel_count(); ++i) {
      try {
        const std::int64_t bx = lo_brick.x + i % n.x, by = lo_brick.y + (i / n.x) % n.y, bz = lo_brick.z + i / (n.x * n.y);
        decode_brick({std::uint8_t(level), std::int32_t(bx), std::int32_t(by), std::int32_t(bz)}, k, brick,
                     reconstructor, scratch);
        const Box part = geometry_->brick_core_box(level, bx, by, bz).intersect(box);
        for (std::int64_t z = part.lo.z; z < part.hi.z; ++z)
          for (std::int64_t y = part.lo.y; y < part.hi.y; ++y) {
            const std::int64_t lz = z - bz * c + l.overlap, ly = y - by * c + l.overlap, lx = part.lo.x - bx * c + l.overlap;
            const float* src = brick.data() + (lz * l.brick + ly) * l.brick + lx;
            std::copy(src, src + (part.hi.x - part.lo.x), &view(part.lo.x - box.lo.x, y - box.lo.y, z - box.lo.z));
          }
      } catch (...) {
#pragma omp critical
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  return out;
}

}  // namespace strata::ta
