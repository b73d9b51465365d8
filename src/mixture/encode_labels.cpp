// encode_labels(): a label volume -> histogram mipmap -> Mixture Graph -> .strata file (graph
// bitstream, label map, per-level node ids, metadata). Layout: docs/format.md, "Codec mixture-graph".
#include "strata/mixture/encoded_labels.hpp"

#include <algorithm>
#include <chrono>
#include <optional>

#include "mixture/encoded_labels_format.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/io/files.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/store/container.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::mixture {

namespace {

// Share of level-0 voxels whose original label is 0 (Table 2's "background"); 0 when absent.
double background_fraction(const MipLevel& level0, const LabelMap& map) {
  const std::optional<std::uint32_t> zero = map.id_of(0);
  if (!zero || level0.ids.empty()) return 0.0;
  const auto n = std::count(level0.ids.begin(), level0.ids.end(), *zero);
  return double(n) / double(level0.ids.size());
}

// The normals graph: the label volume's quantized normal codes encoded as labels of their own
// into a temporary file beside `out`, whose bytes become section "normals".
nlohmann::json add_normals(const Volume& labels, const std::filesystem::path& out, const EncodeOptions& options,
                           store::ContainerWriter& writer, EncodeReport& rep) {
  const auto start = std::chrono::steady_clock::now();
  const LabelNormals normals = quantize_label_normals(labels, options.normal_options);
  const std::filesystem::path dir = out.has_parent_path() ? out.parent_path() : std::filesystem::path(".");
  const io::TempFile nested(dir, "." + out.filename().string() + ".normals");
  EncodeOptions inner = options;
  inner.normals = false;
  inner.measure_error = false;
  encode_labels(normals.codes, nested.path(), inner);
  const io::MappedFile bytes(nested.path());
  writer.add_section("normals", std::span(bytes.data(), std::size_t(bytes.size())));
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

EncodeReport encode_labels(const Volume& labels, const std::filesystem::path& out, const EncodeOptions& options,
                           ProgressSink& progress) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  if (options.ids_zstd < 0 || options.ids_zstd > 22)
    throw Error("ids zstd level: must be 0..22, got " + std::to_string(options.ids_zstd));
  if (options.bits < 1 || options.bits > 16) throw Error("bits: must be 1..16, got " + std::to_string(options.bits));
  LabelMap map;
  HistogramMipmap h = HistogramMipmap::from_labels(labels, &map, progress);
  const MipmapStats ms = h.stats();
  const int mip_levels = h.level_count();
  const double background = background_fraction(h.level(0), map);
  FactorOptions fo;
  fo.score = options.strategy;
  fo.bits = options.bits;
  fo.bins = options.bins;
  fo.tau = options.tau;
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
  rep.background_fraction = background;
  rep.factor_seconds = f.stats.seconds;
  rep.level0_voxels = std::uint64_t(labels.dims().voxel_count());

  std::vector<std::byte> graph_bytes = write_graph_bitstream(f.graph, h.fractional(), labels.dims());
  if (options.measure_error) {
    // Measured on the graph as stored (20-bit codebook), i.e. what a reader reconstructs.
    f.graph = read_graph_bitstream(graph_bytes, out.string());
    const Schedule s = make_schedule(f.graph);
    const MixtureLookup lut = MixtureLookup::build(f.graph, s);
    rep.max_l1 = measure_error(h, f, lut).max_l1;
  }

  store::ContainerWriter writer(out);
  std::optional<nlohmann::json> normals_meta;
  if (options.normals) normals_meta = add_normals(labels, out, options, writer, rep);
  writer.add_section("mixture_graph", graph_bytes);
  rep.graph_bytes = graph_bytes.size();
  ByteWriter lm;
  lm.put(std::uint32_t(map.size()));
  for (std::int64_t v : map.values()) lm.put(v);
  const std::vector<std::byte> label_map_bytes = lm.take();
  writer.add_section("label_map", label_map_bytes);
  rep.label_map_bytes = label_map_bytes.size();

  nlohmann::json levels = nlohmann::json::array();
  {
    ProgressTask task(progress, "store ids", f.levels.size(), "levels");
    for (std::size_t l = 0; l < f.levels.size(); ++l) {
      const MipLevel& lv = f.levels[l];
      std::vector<std::byte> bytes = options.ids == IdsMode::fixed ? FixedRateIds(lv.ids, lv.dims).serialize()
                                                                   : BlockPaletteIds(lv.ids, lv.dims).serialize();
      if (options.ids_zstd > 0) bytes = store::zstd_compress(bytes, options.ids_zstd);
      writer.add_section(detail::level_section(int(l)), bytes);
      rep.ids_bytes.push_back(bytes.size());
      levels.push_back({{"dims", detail::extent_json(lv.dims)}, {"ids_bytes", bytes.size()}});
      task.advance(1);
    }
  }

  const Spacing sp = labels.spacing();
  nlohmann::json stats{{"nodes", rep.nodes},
                       {"internal_nodes", rep.internal_nodes},
                       {"sources", rep.sources},
                       {"depth", rep.depth},
                       {"distinct_mixtures", rep.distinct_mixtures},
                       {"input_pairs", rep.input_pairs},
                       {"factor_seconds", rep.factor_seconds}};
  if (rep.max_l1) stats["max_l1_error"] = *rep.max_l1;
  nlohmann::json meta{{"codec", kMixtureCodecName},
                      {"mixture_graph_version", detail::kFormatVersion},
                      {"source",
                       {{"dims", detail::extent_json(labels.dims())},
                        {"dtype", std::string(dtype_name(labels.dtype()))},
                        {"spacing", {sp.x, sp.y, sp.z}}}},
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
  rep.file_bytes = writer.finish(meta);
  rep.bits_per_voxel = 8.0 * double(rep.file_bytes) / double(std::max<std::uint64_t>(1, rep.level0_voxels));
  rep.seconds = std::chrono::duration<double>(clock::now() - t0).count();
  return rep;
}

EncodeReport encode_labels(io::VolumeSource& labels, const std::filesystem::path& out, const EncodeOptions& options,
                           ProgressSink& progress) {
  // The histogram mipmap needs every level-0 id in memory anyway (one u32 per voxel).
  const Volume v = labels.read_all();
  return encode_labels(v, out, options, progress);
}

}  // namespace strata::mixture
