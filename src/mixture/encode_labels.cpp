// encode_labels(): a label volume -> histogram mipmap -> Mixture Graph -> .strata file (graph
// bitstream, label map, per-level node ids, metadata). Layout: docs/format.md, "Codec mixture-graph".
//
// The volume is streamed in z-slabs, twice: a first pass collects the label values (the label
// map), a second maps each slab to source ids, which go straight into level 0's id section and
// into level 1 of the mipmap. Level 0 (one u32 per voxel, 7/8 of the mipmap) is therefore never
// held whole; the coarser levels, the table of distinct mixtures and the factorisation are.
#include "strata/mixture/encoded_labels.hpp"

#include <algorithm>
#include <chrono>

#include <fmt/format.h>
#include <optional>
#include <variant>

#include "mixture/encode_steps.hpp"
#include "mixture/encoded_labels_format.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/io/files.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/store/container.hpp"
#include "strata/store/geometry_json.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::mixture {

namespace {

// Allowance within a memory limit for what is not proportional to the volume: code, the label
// map, level 0's id storage (a few bits per voxel), allocator slack.
constexpr std::uint64_t kBaselineBytes = 64ull << 20;

// Slabs are whole 8-slice block rows of level 0's block-palette ids (and so an even number of
// slices, as level 1 of the mipmap needs).
constexpr std::int64_t kSlabMultiple = BlockPaletteIds::kBlock;

// Levels 1.. of the mipmap: one u32 per voxel, held until the ids are stored.
std::uint64_t coarse_ids_bytes(const Extent& dims) {
  std::uint64_t bytes = 0;
  const std::vector<Extent> levels = mip_level_dims(dims);
  for (std::size_t l = 1; l < levels.size(); ++l) bytes += 4 * std::uint64_t(levels[l].voxel_count());
  return bytes;
}

std::string mib(std::uint64_t bytes) { return std::to_string((bytes + (1 << 20) - 1) >> 20) + " MiB"; }

}  // namespace

std::int64_t label_slab_slices(const VolumeInfo& info, std::uint64_t memory_limit) {
  // A slab costs its samples and one u32 source id per voxel.
  const std::uint64_t per_slice = std::uint64_t(info.dims.x * info.dims.y) * (dtype_size(info.dtype) + 4);
  const std::int64_t fewest = std::min<std::int64_t>(kSlabMultiple, info.dims.z);
  std::uint64_t budget = io::kDefaultSlabBytes;
  if (memory_limit > 0) {
    const std::uint64_t fixed = kBaselineBytes + coarse_ids_bytes(info.dims);
    const std::uint64_t needed = fixed + std::uint64_t(fewest) * per_slice;
    if (memory_limit < needed)
      throw ParameterError("EncodeOptions::memory_limit",
                           "encoding labels of " + info.dims.to_string() + " needs at least " + mib(needed) + " (" +
                               mib(coarse_ids_bytes(info.dims)) + " for the ids of the coarser mip levels, " +
                               mib(std::uint64_t(fewest) * per_slice) + " for one slab of " + std::to_string(fewest) +
                               " slices, " + mib(kBaselineBytes) + " for the rest), got " + mib(memory_limit));
    budget = std::min(budget, memory_limit - fixed);
  }
  const std::int64_t slices = std::int64_t(budget / per_slice) / kSlabMultiple * kSlabMultiple;
  return std::clamp<std::int64_t>(slices, fewest, std::max<std::int64_t>(fewest, info.dims.z));
}

namespace detail {

namespace {

// The bytes of one ids_L<n> section: the serialized id storage, zstd-compressed if asked.
std::vector<std::byte> compress_section(std::vector<std::byte> bytes, const EncodeOptions& options) {
  if (options.ids_zstd > 0) bytes = store::zstd_compress(bytes, options.ids_zstd);
  return bytes;
}

std::vector<std::byte> id_section(std::span<const std::uint32_t> ids, const Extent& dims, const EncodeOptions& options) {
  return compress_section(options.ids == IdsMode::fixed ? FixedRateIds(ids, dims).serialize()
                                                        : BlockPaletteIds(ids, dims).serialize(),
                          options);
}

}  // namespace

Level0Ids::Level0Ids(const Extent& dims, std::uint32_t sources, IdsMode mode)
    : builder_(mode == IdsMode::fixed ? decltype(builder_)(FixedRateIds::Builder(dims, 0, sources - 1))
                                      : decltype(builder_)(BlockPaletteIds::Builder(dims))) {}

void Level0Ids::append_part(std::span<const std::byte> part) {
  if (auto* fixed = std::get_if<FixedRateIds::Builder>(&builder_)) {
    fixed->append_part(FixedRateIds::deserialize(part));
  } else {
    std::get<BlockPaletteIds::Builder>(builder_).append_part(BlockPaletteIds::deserialize(part));
  }
}

std::vector<std::byte> Level0Ids::part_bytes() {
  return std::visit([](auto& b) { return b.finish().serialize(); }, builder_);
}

std::vector<std::byte> Level0Ids::section(const EncodeOptions& options) { return compress_section(part_bytes(), options); }

LabelMap collect_label_map(io::VolumeSource& source, io::SliceSpan span, std::int64_t slab, ProgressSink& progress) {
  LabelValueCollector values(source.info().dtype);
  io::for_each_slab(source, span, slab, [&](const Volume& v, std::int64_t) { values.add(v); }, progress,
                    "label values");
  return values.finish();
}

void stream_ids(io::VolumeSource& source, io::SliceSpan span, std::int64_t slab, const LabelMap& map,
                HistogramMipmap::StreamBuilder& mipmap, Level0Ids& level0, ProgressSink& progress) {
  std::vector<std::uint32_t> ids;
  io::for_each_slab(
      source, span, slab,
      [&](const Volume& v, std::int64_t) {
        assign_source_ids(v, map, ids);
        mipmap.append(ids);
        level0.append(ids);
      },
      progress, "level 0");
}

StreamedLabels finish_streamed(LabelMap map, HistogramMipmap::StreamBuilder& mipmap, Level0Ids& level0,
                               const EncodeOptions& options, ProgressSink& progress) {
  StreamedLabels out;
  if (const std::optional<std::uint32_t> zero = map.id_of(0)) out.zero_voxels = mipmap.level0_counts()[*zero];
  out.map = std::move(map);
  out.mipmap = mipmap.finish(progress);
  out.level0_section = level0.section(options);
  return out;
}

}  // namespace detail

void validate(const EncodeOptions& options) {
  if (options.bits < 1 || options.bits > kMaxWeightBits)
    throw ParameterError("EncodeOptions::bits", fmt::format("must be 1..{}, got {}", kMaxWeightBits, options.bits));
  if (options.ids_zstd < 0 || options.ids_zstd > kMaxIdsZstdLevel)
    throw ParameterError("EncodeOptions::ids_zstd",
                         fmt::format("must be 0 (off) to {}, got {}", kMaxIdsZstdLevel, options.ids_zstd));
  options.normal_options.validate();
}

namespace {

// The normals graph: the label volume's quantized normal codes encoded as labels of their own
// into a temporary file beside `out`, whose bytes become section "normals".
nlohmann::json add_normals(const Volume& labels, const std::filesystem::path& out, const EncodeOptions& options,
                           store::ContainerWriter& writer, EncodeReport& rep) {
  const auto start = std::chrono::steady_clock::now();
  const LabelNormals normals = quantize_label_normals(labels, options.normal_options);
  const std::filesystem::path dir = out.has_parent_path() ? out.parent_path() : std::filesystem::path(".");
  const io::TempFile nested(dir, fmt::format(".{}.normals", out.filename().string()));
  EncodeOptions inner = options;
  inner.normals = false;
  inner.measure_error = false;
  encode_labels(normals.codes, nested.path(), inner);
  const io::MappedFile bytes(nested.path());
  writer.add_container_section("normals", std::span(bytes.data(), std::size_t(bytes.size())));
  rep.normals_bytes = bytes.size();
  rep.normals_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const NormalOptions& o = options.normal_options;
  return {{"codebook", "fibonacci-511"},
          {"radius", o.radius},
          {"band", o.band},
          {"diffusion", o.diffusion},
          {"error_diffusion", o.error_diffusion},
          {"band_voxels", normals.band_voxels},
          {"interior_voxels", normals.interior_voxels},
          {"seconds", rep.normals_seconds}};
}

}  // namespace

namespace detail {

EncodeReport write_labels_file(StreamedLabels s, const VolumeInfo& info, const Volume* whole,
                               const std::filesystem::path& out, const EncodeOptions& options, ProgressSink& progress,
                               std::chrono::steady_clock::time_point start) {
  HistogramMipmap& h = s.mipmap;
  const MipmapStats ms = h.stats();
  const int mip_levels = h.level_count();
  FactorOptions fo;
  fo.score = options.strategy;
  fo.bits = options.bits;
  fo.bins = options.bins;
  fo.tau = options.tau;
  fo.park_dir = out.has_parent_path() ? out.parent_path() : std::filesystem::path(".");
  // Consumes the mipmap's id arrays (the largest buffers) instead of copying them; only its
  // table is needed afterwards.
  Factorization f = factorize(std::move(h), fo, progress);

  EncodeReport rep;
  rep.nodes = f.stats.nodes;
  rep.internal_nodes = f.stats.internal_nodes;
  rep.sources = f.graph.num_sources;
  rep.depth = f.stats.depth;
  rep.distinct_mixtures = ms.distinct_mixtures;
  rep.input_pairs = ms.input_pairs;
  rep.mip_levels = mip_levels;
  rep.mip_voxels = ms.voxels;
  rep.nnz_per_voxel = ms.nnz_per_voxel;
  rep.raw_histogram_bytes = ms.nnz_total * 8;
  rep.level0_voxels = std::uint64_t(info.dims.voxel_count());
  // Share of level-0 voxels whose original label is 0 (Table 2's "background").
  rep.background_fraction = rep.level0_voxels ? double(s.zero_voxels) / double(rep.level0_voxels) : 0.0;
  rep.factor_seconds = f.stats.seconds;

  std::vector<std::byte> graph_bytes = write_graph_bitstream(f.graph, h.fractional(), info.dims);
  if (options.measure_error) {
    // Measured on the graph as stored (20-bit codebook), i.e. what a reader reconstructs.
    f.graph = read_graph_bitstream(graph_bytes, out.string());
    const Schedule sched = make_schedule(f.graph);
    const MixtureLookup lut = MixtureLookup::build(f.graph, sched);
    rep.max_l1 = measure_error(h, f, lut).max_l1;
  }

  store::ContainerWriter writer(out);
  std::optional<nlohmann::json> normals_meta;
  if (options.normals) normals_meta = add_normals(*whole, out, options, writer, rep);
  writer.add_section("mixture_graph", graph_bytes);
  rep.graph_bytes = graph_bytes.size();
  ByteWriter lm;
  lm.put(std::uint32_t(s.map.size()));
  for (std::int64_t v : s.map.values()) lm.put(v);
  const std::vector<std::byte> label_map_bytes = lm.take();
  writer.add_section("label_map", label_map_bytes);
  rep.label_map_bytes = label_map_bytes.size();

  nlohmann::json levels = nlohmann::json::array();
  {
    ProgressTask task(progress, "store ids", f.levels.size(), "levels");
    for (std::size_t l = 0; l < f.levels.size(); ++l) {
      MipLevel& lv = f.levels[l];
      // Level 0 was stored as it streamed past; the others are released once stored.
      const std::vector<std::byte> bytes = l == 0 ? std::move(s.level0_section) : id_section(lv.ids, lv.dims, options);
      lv.ids = {};
      writer.add_section(detail::level_section(int(l)), bytes);
      rep.ids_bytes.push_back(bytes.size());
      levels.push_back({{"dims", detail::extent_json(lv.dims)}, {"ids_bytes", bytes.size()}});
      task.advance(1);
    }
  }

  const Spacing sp = info.spacing;
  nlohmann::json stats{{"nodes", rep.nodes},
                       {"internal_nodes", rep.internal_nodes},
                       {"sources", rep.sources},
                       {"depth", rep.depth},
                       {"distinct_mixtures", rep.distinct_mixtures},
                       {"input_pairs", rep.input_pairs},
                       {"factor_seconds", rep.factor_seconds}};
  if (rep.max_l1) stats["max_l1_error"] = *rep.max_l1;
  nlohmann::json source{{"dims", detail::extent_json(info.dims)},
                        {"dtype", std::string(dtype_name(info.dtype))},
                        {"spacing", {sp.x, sp.y, sp.z}}};
  if (!info.geometry.is_default()) source["geometry"] = store::geometry_to_json(info.geometry);
  nlohmann::json meta{{"codec", kMixtureCodecName},
                      {"mixture_graph_version", detail::kFormatVersion},
                      {"source", source},
                      {"levels", levels},
                      {"ids", std::string(ids_mode_name(options.ids))},
                      {"ids_compression", options.ids_zstd > 0 ? "zstd" : "none"},
                      {"bits", options.bits},
                      {"bins", std::string(weight_bins_name(options.bins))},
                      {"strategy", std::string(strategy_name(options.strategy))},
                      {"tau", options.tau},
                      {"fractional", h.fractional()},
                      {"stats", stats}};
  if (normals_meta) meta["normals"] = *normals_meta;
  // Names of labels that occur: the viewer selects by name, and a selection must name labels
  // of the file (a names table often covers a whole atlas, of which a crop holds part).
  LabelNames names;
  for (const auto& [label, name] : options.names)
    if (s.map.id_of(label)) names.emplace(label, name);
  rep.names = names.size();
  if (!names.empty()) meta["label_names"] = label_names_json(names);
  rep.file_bytes = writer.finish(meta);
  rep.bits_per_voxel = 8.0 * double(rep.file_bytes) / double(std::max<std::uint64_t>(1, rep.level0_voxels));
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return rep;
}

}  // namespace detail

namespace {

// Streams `source` and writes the file; `whole` is the same volume in memory when the normals
// graph needs it (null otherwise).
EncodeReport encode_streamed(io::VolumeSource& source, const Volume* whole, const std::filesystem::path& out,
                             const EncodeOptions& options, ProgressSink& progress) {
  const auto start = std::chrono::steady_clock::now();
  validate(options);
  const VolumeInfo info = source.info();
  const std::int64_t slab = label_slab_slices(info, options.memory_limit);
  const io::SliceSpan all{0, info.dims.z};
  LabelMap map = detail::collect_label_map(source, all, slab, progress);
  HistogramMipmap::StreamBuilder mipmap(info.dims, map.size());
  detail::Level0Ids level0(info.dims, map.size(), options.ids);
  detail::stream_ids(source, all, slab, map, mipmap, level0, progress);
  detail::StreamedLabels s = detail::finish_streamed(std::move(map), mipmap, level0, options, progress);
  return detail::write_labels_file(std::move(s), info, whole, out, options, progress, start);
}

}  // namespace

EncodeReport encode_labels(const Volume& labels, const std::filesystem::path& out, const EncodeOptions& options,
                           ProgressSink& progress) {
  const std::unique_ptr<io::VolumeSource> source = io::memory_source(labels);
  return encode_streamed(*source, &labels, out, options, progress);
}

EncodeReport encode_labels(io::VolumeSource& labels, const std::filesystem::path& out, const EncodeOptions& options,
                           ProgressSink& progress) {
  if (!options.normals) return encode_streamed(labels, nullptr, out, options, progress);
  // The normals are estimated over the whole volume (a window around every boundary voxel).
  const Volume whole = labels.read_all();
  return encode_streamed(labels, &whole, out, options, progress);
}

}  // namespace strata::mixture
