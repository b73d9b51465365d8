#include "strata/ta/evaluate.hpp"

#include <chrono>
#include <cmath>

#include <algorithm>

#include "strata/core/error.hpp"
#include "strata/quant/coded_brick.hpp"
#include "ta/non_finite.hpp"

namespace strata::ta {

double StorageReport::bits_per_voxel(std::uint64_t bytes, const VolumeInfo& source) const {
  return 8.0 * double(bytes) / double(source.dims.voxel_count());
}

namespace {

// The range-coded stream cannot be split exactly; it is attributed to the core and the factors
// in proportion to their non-zero codes (zeros cost a small fraction of a bit).
void add_coded_parts(const quant::CodedBrick& b, std::size_t payload_bytes, StorageReport& r) {
  const std::size_t header = quant::coded_header_bytes(b);
  const auto nonzero = [](const std::vector<std::int32_t>& v) {
    return double(std::count_if(v.begin(), v.end(), [](std::int32_t x) { return x != 0; }));
  };
  const double core = nonzero(b.core_codes), factors = nonzero(b.factor_codes), corrections = double(b.correction_codes.size());
  const double total = core + factors + corrections;
  const std::size_t stream = payload_bytes - header;
  const auto core_bytes = std::uint64_t(total > 0 ? double(stream) * core / total : 0);
  const auto factor_bytes = std::uint64_t(total > 0 ? double(stream) * factors / total : 0);
  r.core_bytes += core_bytes;
  r.factor_bytes += factor_bytes;
  r.correction_bytes += stream - core_bytes - factor_bytes;
  r.brick_header_bytes += header;
}

}  // namespace

namespace {

// Attributes one stored payload of `kind` to the report's parts; a masked brick's mask, then
// its inner brick.
void add_payload(store::PayloadKind kind, std::span<const std::byte> stored, const TaVolume& volume,
                 DecodeScratch& scratch, StorageReport& r) {
  const auto& c = volume.container();
  const int brick = volume.geometry().layout().brick;
  switch (store::payload_kind_traits(kind).decoder) {
    case store::PayloadDecoder::none: return;
    case store::PayloadDecoder::masked: {
      const std::size_t voxels = std::size_t(brick) * std::size_t(brick) * std::size_t(brick);
      const MaskedPayload m = unwrap_masked(stored, voxels, scratch.inflated, c.name());
      r.mask_bytes += stored.size() - m.inner_payload.size();
      return add_payload(m.inner, m.inner_payload, volume, scratch, r);
    }
    case store::PayloadDecoder::lossless: r.lossless_bytes += stored.size(); return;
    case store::PayloadDecoder::coded_tucker:
      add_coded_parts(quant::deserialize_coded(stored, brick, c.name()), stored.size(), r);
      return;
    case store::PayloadDecoder::tucker:
    case store::PayloadDecoder::global_core: break;
  }
  const auto plain = plain_payload(kind, stored, volume.quant_scheme(), scratch, c.name());
  const auto parts = payload_parts(plain, volume.quant_scheme(), c.name());
  const double ratio = double(stored.size()) / double(plain.size());
  const auto core = std::uint64_t(double(parts.core_bytes) * ratio);
  const auto factors = std::uint64_t(double(parts.factor_bytes) * ratio);
  r.core_bytes += core;
  r.factor_bytes += factors;
  r.brick_header_bytes += stored.size() - core - factors;
}

// A remote file's payloads are fetched this many bricks at a time, in few requests, rather than
// with one request each.
constexpr std::size_t kPrefetchBricks = 4096;

void prefetch_from(const store::ContainerReader& c, std::size_t first) {
  std::vector<const store::BrickEntry*> batch;
  for (std::size_t i = first; i < std::min(c.bricks().size(), first + kPrefetchBricks); ++i) batch.push_back(&c.bricks()[i]);
  c.prefetch(batch);
}

}  // namespace

StorageReport storage_report(const TaVolume& volume) {
  const auto& c = volume.container();
  StorageReport r;
  r.file_bytes = c.file_size();
  r.bricks_per_level.assign(std::size_t(volume.geometry().level_count()), 0);
  r.constant_per_level = r.bricks_per_level;
  r.payload_bytes_per_level.assign(r.bricks_per_level.size(), 0);
  DecodeScratch scratch;
  std::uint64_t payload_total = 0;
  for (std::size_t i = 0; i < c.bricks().size(); ++i) {
    const store::BrickEntry& e = c.bricks()[i];
    if (i % kPrefetchBricks == 0) prefetch_from(c, i);
    ++r.bricks_per_level.at(e.key.level);
    payload_total += e.size;
    r.payload_bytes_per_level[e.key.level] += e.size;
    if (e.kind == store::PayloadKind::constant) {
      ++r.constant_per_level[e.key.level];
      continue;
    }
    const io::SharedBytes payload = c.payload(e);
    add_payload(e.kind, payload, volume, scratch, r);
  }
  std::uint64_t sections = 0;
  if (volume.global()) {
    // The global bases are this codec's factors; the table is what its LOD reads.
    const std::uint64_t bases = c.section("global_bases").size();
    r.feature_scale_bytes = c.section("feature_scale").size();
    r.factor_bytes += bases;
    sections = bases + r.feature_scale_bytes;
  }
  r.container_bytes = r.file_bytes - payload_total - sections;
  return r;
}

namespace {

void check_same_dims(const TaVolume& volume, io::VolumeSource& original) {
  const Extent dims = volume.source_info().dims;
  if (!(original.info().dims == dims))
    throw Error(original.path().string() + ": dims " + original.info().dims.to_string() +
                " differ from the compressed volume's " + dims.to_string());
}

// Slabs of the original start at multiples of the coarsest cell, so halving a slab level by
// level gives exactly those levels' slices of the whole pyramid.
std::vector<ErrorMetrics> coarse_errors(const TaVolume& volume, io::VolumeSource& original, int k) {
  const int levels = volume.geometry().level_count();
  if (levels < 2) return {};
  const Extent dims = volume.source_info().dims;
  const std::int64_t cell = std::int64_t(1) << (levels - 1);
  const std::int64_t wanted = std::max<std::int64_t>(cell, volume.geometry().layout().core() * 4);
  const std::int64_t rows = (wanted + cell - 1) / cell * cell;
  std::vector<ErrorAccumulator> acc(std::size_t(levels - 1));
  for (std::int64_t z0 = 0; z0 < dims.z; z0 += rows) {
    Volume slab = original.read_slab(z0, std::min(dims.z, z0 + rows)).converted(DType::f32);
    for (int l = 1; l < levels; ++l) {
      slab = half_resolution(slab);
      const Extent level_dims = volume.geometry().level(l).dims;
      const std::int64_t lz0 = z0 >> l;
      acc[std::size_t(l - 1)].add(slab, volume.decode_box(l, {{0, 0, lz0}, {level_dims.x, level_dims.y, lz0 + slab.dims().z}}, k));
    }
  }
  std::vector<ErrorMetrics> out;
  for (const ErrorAccumulator& a : acc) out.push_back(a.result());
  return out;
}

}  // namespace

ErrorReport error_report(const TaVolume& volume, io::VolumeSource& original, int k, bool coarse_levels) {
  const Extent dims = volume.source_info().dims;
  check_same_dims(volume, original);
  const std::int64_t rows = volume.geometry().layout().core() * 4;  // a few brick rows per slab
  ErrorAccumulator acc;
  ErrorReport r;
  r.rank = k;
  for (std::int64_t z0 = 0; z0 < dims.z; z0 += rows) {
    const std::int64_t z1 = std::min(dims.z, z0 + rows);
    const auto t = std::chrono::steady_clock::now();
    Volume decoded = volume.decode_box(0, {{0, 0, z0}, {dims.x, dims.y, z1}}, k);
    r.decode_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    acc.add(original.read_slab(z0, z1), decoded);
  }
  r.metrics = acc.result();
  if (coarse_levels) r.coarse = coarse_errors(volume, original, k);
  return r;
}

}  // namespace strata::ta
