#include "strata/ta/ta_volume.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/core/text.hpp"
#include "strata/core/threads.hpp"
#include "strata/store/brick_histogram.hpp"
#include "strata/store/geometry_json.hpp"
#include "strata/store/metadata_json.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/target_codec.hpp"

namespace strata::ta {

namespace {

using store::json_member;
using store::json_object;
using store::MetadataField;

// "a, b or c": the payload kinds a codec writes, for messages.
std::string kind_list(const std::vector<store::PayloadKind>& kinds) {
  std::vector<std::string> names;
  for (store::PayloadKind k : kinds) names.emplace_back(store::payload_kind_name(k));
  return joined_list(names, "or");
}

std::string extent_text(const Extent& e) { return fmt::format("[{}, {}, {}]", e.x, e.y, e.z); }

// A remote file fetches the payloads of the n bricks from `lo` of `level` in a few coalesced
// requests before the decoding threads ask for them one by one (decode_brick reports missing
// bricks).
void prefetch_bricks(const store::ContainerReader& container, int level, const Extent& lo, const Extent& n) {
  if (!container.source().remote()) return;
  std::vector<const store::BrickEntry*> entries;
  for (std::int64_t i = 0; i < n.voxel_count(); ++i)
    entries.push_back(container.find({std::uint8_t(level), std::int32_t(lo.x + i % n.x), std::int32_t(lo.y + (i / n.x) % n.y),
                                      std::int32_t(lo.z + i / (n.x * n.y))}));
  container.prefetch(entries);
}

}  // namespace

TaVolume::TaVolume(const std::filesystem::path& path) : TaVolume(std::make_unique<store::ContainerReader>(path)) {}

// Everything docs/format.md defines for a ta-bricked file is checked here, against itself and
// against the index, before any brick is decoded: a forged or damaged file fails with the file,
// the field and what was expected instead of decoding with the wrong geometry.
TaVolume::TaVolume(std::unique_ptr<store::ContainerReader> container) : container_(std::move(container)) {
  const std::string file = container_->name();
  const nlohmann::json& m = container_->metadata();
  const MetadataField meta{file, "metadata"};
  const auto codec = m.find("codec");
  if (codec == m.end() || !codec->is_string() || !is_codec_name(codec->get_ref<const std::string&>()))
    throw FormatError(file, "metadata.codec",
                      "expected " + quoted_codec_names() + ", found " +
                          (codec != m.end() ? store::json_excerpt(*codec) : std::string("none")));
  codec_name_ = codec->get_ref<const std::string&>();
  const bool global = codec_name_ == kGlobalCodecName;
  store::json_integer(json_member(m, "codec_version", meta), meta / "codec_version", 1, 1);

  const MetadataField src = meta / "source";
  const nlohmann::json& source = json_object(json_member(m, "source", meta), src);
  // Extents and brick coordinates are 32-bit in the index.
  const auto dims = store::json_integers(json_member(source, "dims", src), 3, src / "dims", 1, INT32_MAX);
  source_.dims = {dims[0], dims[1], dims[2]};
  const std::string dtype = store::json_string(json_member(source, "dtype", src), src / "dtype");
  try {
    source_.dtype = parse_dtype(dtype, "metadata.source.dtype");
  } catch (const Error&) {
    (src / "dtype").fail("unknown sample type \"" + dtype + "\" (expected u8, i8, u16, i16, u32, i32, u64, i64, f32 or f64)");
  }
  const auto spacing = store::json_positive_numbers(json_member(source, "spacing", src), 3, src / "spacing");
  source_.spacing = {spacing[0], spacing[1], spacing[2]};
  source_.geometry = store::geometry_from_json(source, src);
  const auto range = store::json_numbers(json_member(source, "value_range", src), 2, src / "value_range");
  if (range[0] > range[1]) (src / "value_range").fail("expected [min, max] with min <= max, got [" + std::to_string(range[0]) + ", " + std::to_string(range[1]) + "]");
  value_lo_ = range[0];
  value_hi_ = range[1];

  const BrickLayout layout{int(store::json_integer(json_member(m, "brick", meta), meta / "brick", 2, 256)),
                           int(store::json_integer(json_member(m, "overlap", meta), meta / "overlap", 0, 127))};
  if (layout.core() < 1)
    (meta / "brick").fail("width " + std::to_string(layout.brick) + " leaves no core with metadata.overlap " +
                          std::to_string(layout.overlap) + " (the width must exceed 2 * overlap)");
  geometry_ = std::make_unique<OctreeGeometry>(source_.dims, layout);
  rank_ = int(store::json_integer(json_member(m, "rank", meta), meta / "rank", 1, layout.brick));
  quant_ = store::json_string(json_member(m, "quant", meta), meta / "quant");
  // Error-target files say so by their quant; a codec without that mode reads it as a scheme.
  const BrickCodec* const coded_entry =
      quant_ == kCodedQuantName ? find_codec(codec_name_, CodecMode::error_target) : nullptr;
  const bool coded = coded_entry != nullptr;
  const BrickCodec* entry = coded ? coded_entry : find_codec(codec_name_, CodecMode::fixed_rank);
  if (entry == nullptr)  // a codec of error-target mode only, with a fixed-rank scheme
    (meta / "quant").fail("the " + codec_name_ + " codec codes to an error target: expected \"" + kCodedQuantName + "\"");
  const std::vector<store::PayloadKind> kinds = entry->payload_kinds();
  try {
    // Error-target files code every brick with its own steps; the default scheme is never used.
    if (!coded) scheme_ = quant::QuantScheme::parse(quant_);
  } catch (const Error& e) {
    (meta / "quant").fail(e.what());
  }
  if (coded) json_object(json_member(m, "target", meta), meta / "target");

  // The octree the metadata promises, level by level, and the index that must hold it.
  const MetadataField lv = meta / "levels";
  const nlohmann::json& levels = json_member(m, "levels", meta);
  if (!levels.is_array() || int(levels.size()) != geometry_->level_count())
    lv.fail("expected " + std::to_string(geometry_->level_count()) + " levels for dims " + extent_text(source_.dims) +
            ", brick " + std::to_string(layout.brick) + " and overlap " + std::to_string(layout.overlap) + ", got " +
            (levels.is_array() ? std::to_string(levels.size()) : store::json_excerpt(levels)));
  std::vector<std::uint64_t> bricks_per_level(levels.size(), 0);
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const LevelGeometry& g = geometry_->level(int(l));
    for (const char* key : {"dims", "bricks"}) {
      const Extent want = key[0] == 'd' ? g.dims : g.bricks;
      const auto got = store::json_integers(json_member(levels[l], key, lv[l]), 3, lv[l] / key, 1, INT32_MAX);
      if (Extent{got[0], got[1], got[2]} != want)
        (lv[l] / key).fail("expected " + extent_text(want) + " for source.dims " + extent_text(source_.dims) + ", brick " +
                           std::to_string(layout.brick) + " and overlap " + std::to_string(layout.overlap) + ", got " +
                           extent_text({got[0], got[1], got[2]}));
    }
  }
  for (const store::BrickEntry& e : container_->bricks()) {
    const std::string name = store::brick_name(e.key);
    if (e.key.level >= geometry_->level_count())
      throw FormatError(file, "index", name + " lies past the last level " + std::to_string(geometry_->level_count() - 1));
    const Extent& grid = geometry_->level(e.key.level).bricks;
    if (e.key.x < 0 || e.key.y < 0 || e.key.z < 0 || e.key.x >= grid.x || e.key.y >= grid.y || e.key.z >= grid.z)
      throw FormatError(file, "index", name + " lies outside the level's brick grid " + extent_text(grid));
    if (std::find(kinds.begin(), kinds.end(), e.kind) == kinds.end())
      throw FormatError(file, name,
                        std::string("payload kind ") + store::payload_kind_name(e.kind) +
                            (global ? " does not belong in a " + codec_name_ + " file (expected " + kind_list(kinds) + ")"
                                    : " does not belong in a file with quant \"" + quant_ + "\" (expected " +
                                          kind_list(kinds) + ")"));
    if (e.kind != store::PayloadKind::constant && e.size == 0)
      throw FormatError(file, name, std::string("a ") + store::payload_kind_name(e.kind) + " brick needs payload bytes, the index gives it none");
    ++bricks_per_level[e.key.level];
  }
  // Keys are unique and inside the grid, so equal counts mean every brick is present.
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const Extent& grid = geometry_->level(int(l)).bricks;
    const auto want = grid.checked_voxel_count();
    if (want && bricks_per_level[l] == std::uint64_t(*want)) continue;
    // Keys are unique and inside the grid, so some brick is missing; the first one is found
    // within bricks_per_level + 1 lookups.
    std::string missing;
    for (std::int64_t i = 0; missing.empty(); ++i) {
      const store::BrickKey key{std::uint8_t(l), std::int32_t(i % grid.x), std::int32_t(i / grid.x % grid.y),
                                std::int32_t(i / grid.x / grid.y)};
      if (!container_->find(key)) missing = store::brick_name(key) + " is missing: ";
    }
    throw FormatError(file, "index",
                      missing + "level " + std::to_string(l) + " has " + std::to_string(bricks_per_level[l]) + " bricks, its grid " +
                          extent_text(grid) + " needs " + (want ? std::to_string(*want) : std::string("more than 2^63")));
  }
  build_subtree_histograms();
  if (global) read_global(meta);
}

// metadata.global and the sections global_bases and feature_scale (docs/format.md, "Codec
// ta-global"), checked against the geometry before any brick is decoded.
void TaVolume::read_global(const store::MetadataField& meta) {
  const std::string& file = container_->name();
  const nlohmann::json& m = container_->metadata();
  const store::MetadataField g = meta / "global";
  const nlohmann::json& global = json_object(json_member(m, "global", meta), g);
  const int brick = geometry_->layout().brick;
  const auto ranks = store::json_integers(json_member(global, "ranks", g), 3, g / "ranks", 1, brick);
  const nlohmann::json& ladder = json_member(global, "ladder", g);
  if (!ladder.is_array() || ladder.empty() || ladder.size() > std::size_t(brick))
    (g / "ladder").fail("expected 1 to " + std::to_string(brick) + " ranks, got " + store::json_excerpt(ladder));
  const int lowest = int(std::min({ranks[0], ranks[1], ranks[2]}));
  for (std::size_t i = 0; i < ladder.size(); ++i) {
    ladder_.push_back(int(store::json_integer(ladder[i], (g / "ladder")[i], 1, lowest)));
    if (i > 0 && ladder_[i] <= ladder_[i - 1]) ((g / "ladder")[i]).fail("ranks must increase");
  }
  const io::SharedBytes bases = container_->section("global_bases");
  bases_ = std::make_unique<GlobalBases>(
      GlobalBases::deserialize(bases, *geometry_, {int(ranks[0]), int(ranks[1]), int(ranks[2])}, file));
  const auto table = container_->section("feature_scale");
  const std::uint64_t rows = std::uint64_t(geometry_->total_bricks());
  if (table.size() != rows * ladder_.size() * sizeof(float))
    throw FormatError(file, "section feature_scale",
                      fmt::format("{} bytes, expected {} ({} bricks × {} ladder ranks × 4)", table.size(),
                                  rows * ladder_.size() * sizeof(float), rows, ladder_.size()));
  feature_scale_.resize(rows * ladder_.size());
  std::memcpy(feature_scale_.data(), table.data(), table.size());
  for (float e : feature_scale_)
    if (!(e >= 0) || !std::isfinite(e))
      throw FormatError(file, "section feature_scale", fmt::format("holds {}; expected RMSEs, finite and >= 0", e));
  // Alg. 2 picks the lowest rank meeting a target: a row that grows with the rank would break it.
  const std::size_t width = ladder_.size();
  for (std::size_t row = 0; row < rows; ++row)
    for (std::size_t i = 1; i < width; ++i)
      if (feature_scale_[row * width + i] > feature_scale_[row * width + i - 1])
        throw FormatError(file, "section feature_scale",
                          fmt::format("row {} grows from rank {} to rank {}; expected RMSEs that never increase", row,
                                      ladder_[i - 1], ladder_[i]));
}


BrickBases TaVolume::brick_bases(const store::BrickKey& key) const {
  if (!bases_) throw Error(container_->name() + ": a " + codec_name_ + " file has no global bases");
  return bases_->brick_bases(key.level, key.x, key.y, key.z);
}

std::span<const float> TaVolume::rank_errors(const store::BrickKey& key) const {
  if (!bases_) return {};
  entry(key);  // a key outside the octree is refused by name
  const auto row = std::size_t(geometry_->brick_ordinal(key.level, key.x, key.y, key.z));
  return std::span<const float>(feature_scale_).subspan(row * ladder_.size(), ladder_.size());
}


void TaVolume::build_subtree_histograms() {
  const store::HistogramBinning binning(value_lo_, value_hi_);
  subtree_histograms_.resize(std::size_t(geometry_->level_count()));
  for (int l = 0; l < geometry_->level_count(); ++l)
    subtree_histograms_[std::size_t(l)].assign(std::size_t(geometry_->level(l).bricks.voxel_count()), 0);
  for (const store::BrickEntry& e : container_->bricks()) {
    std::uint64_t own = e.histogram;
    if (e.kind == store::PayloadKind::constant)
      own = std::isfinite(e.min) ? std::uint64_t(1) << binning.bin(e.min) : 0;
    subtree_histograms_[e.key.level][std::size_t(geometry_->brick_ordinal(e.key.level, e.key.x, e.key.y, e.key.z, true))] = own;
  }
  // Level l + 1's brick (x, y, z) covers level l's bricks 2x .. 2x + 1 (and so on): the core
  // width is the same on every level and each level halves the one below.
  for (int l = 0; l + 1 < geometry_->level_count(); ++l) {
    const Extent& grid = geometry_->level(l).bricks;
    for (std::int64_t z = 0; z < grid.z; ++z)
      for (std::int64_t y = 0; y < grid.y; ++y)
        for (std::int64_t x = 0; x < grid.x; ++x)
          subtree_histograms_[std::size_t(l + 1)][std::size_t(geometry_->brick_ordinal(l + 1, x / 2, y / 2, z / 2, true))] |=
              subtree_histograms_[std::size_t(l)][std::size_t(geometry_->brick_ordinal(l, x, y, z, true))];
  }
}

std::uint64_t TaVolume::subtree_histogram(const store::BrickKey& key) const {
  entry(key);  // a key outside the octree is refused by name
  return subtree_histograms_[key.level][std::size_t(geometry_->brick_ordinal(key.level, key.x, key.y, key.z, true))];
}

const store::BrickEntry& TaVolume::entry(const store::BrickKey& key) const {
  const store::BrickEntry* e = container_->find(key);
  if (!e) throw FormatError(container_->name(), "index", store::brick_name(key) + " is missing");
  return *e;
}

void TaVolume::decode_brick(const store::BrickKey& key, int k, std::span<float> out, tensor::BrickReconstructor& reconstructor,
                            DecodeScratch& scratch) const {
  const store::BrickEntry& e = entry(key);
  const io::SharedBytes payload = container_->payload(e);  // its errors name the file and the brick
  const std::string file = container_->name();
  try {
    const BrickBases bases = bases_ ? brick_bases(key) : BrickBases{};
    ta::decode_brick(e.kind, payload, e.min, scheme_, geometry_->layout().brick, std::clamp(k, 1, rank_), reconstructor,
                     scratch, out, file, bases_ ? &bases : nullptr);
  } catch (const Error& error) {
    // The codec prefixes its messages with the context it was given, sometimes at two depths;
    // the user gets one "<file>: <brick>: <problem>".
    std::string problem = error.what();
    const std::string prefix = file + ": ";
    while (problem.compare(0, prefix.size(), prefix) == 0) problem.erase(0, prefix.size());
    throw FormatError(file, store::brick_name(key), problem);
  }
}

void TaVolume::check_level(int level) const {
  if (level < 0 || level >= geometry_->level_count())
    throw ParameterError("level", std::to_string(level) + " is not in 0.." + std::to_string(geometry_->level_count() - 1) +
                                      " for " + container_->name());
}

int TaVolume::reconstruction_rank(int requested) const {
  return ta::reconstruction_rank(requested, rank_, container_->name());
}

int reconstruction_rank(int requested, int stored, std::string_view file) {
  if (requested == 0) return stored;
  if (stored <= 0)
    throw ParameterError("rank", fmt::format("{} stores no Tucker rank (not a tensor-approximation file): expected 0, "
                                             "got {}",
                                             file, requested));
  if (requested < 0 || requested > stored)
    throw ParameterError("rank", fmt::format("expected 1..{} (the stored rank of {}) or 0 for the stored rank, got {}",
                                             stored, file, requested));
  return requested;
}

Geometry TaVolume::level_geometry(int level, const Box& box) const {
  const double scale = std::ldexp(1.0, level);
  const Spacing level_spacing{source_.spacing.x * scale, source_.spacing.y * scale, source_.spacing.z * scale};
  return box_geometry(strata::level_geometry(source_.geometry, source_.spacing, level), level_spacing,
                      {box.lo.x, box.lo.y, box.lo.z});
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
  prefetch_bricks(*container_, level, lo_brick, n);
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
