// Mixture Graph storage in a .strata container: graph bitstream (paper Table 1), label map,
// per-level node ids. Layout: docs/format.md, "Codec mixture-graph".
#include "strata/mixture/encoded_labels.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>


#include "strata/core/bitstream.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/mixture/palette.hpp"
#include "strata/store/container.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::mixture {

namespace {

constexpr int kCodeBits = 20;
constexpr std::uint32_t kCodeMax = (1u << kCodeBits) - 1u;
const double kCodeRoundingVariance = std::ldexp(1.0, -2 * (kCodeBits + 1)) / 3.0;
constexpr int kFormatVersion = 1;

int ceil_log2(std::uint64_t n) {  // bits for values 0..n-1, at least 1
  int b = 1;
  while (b < 64 && (std::uint64_t(1) << b) < n) ++b;
  return b;
}

std::string level_section(int level) { return "ids_L" + std::to_string(level); }

nlohmann::json extent_json(const Extent& e) { return nlohmann::json::array({e.x, e.y, e.z}); }

template <class T>
T field(const nlohmann::json& j, const char* key, const std::string& file, const std::string& where = "") {
  const std::string name = where.empty() ? std::string(key) : where + "." + key;
  if (!j.is_object() || !j.contains(key)) throw FormatError(file, "metadata " + name, "missing");
  try {
    return j.at(key).get<T>();
  } catch (const std::exception&) {
    throw FormatError(file, "metadata " + name, "has the wrong type (" + j.at(key).dump() + ")");
  }
}

Extent meta_extent(const nlohmann::json& j, const std::string& file, const std::string& name) {
  if (!j.is_array() || j.size() != 3) throw FormatError(file, "metadata " + name, "expected [x, y, z]");
  Extent e;
  try {
    e = {j[0].get<std::int64_t>(), j[1].get<std::int64_t>(), j[2].get<std::int64_t>()};
  } catch (const std::exception&) {
    throw FormatError(file, "metadata " + name, "expected three integers");
  }
  if (e.x < 1 || e.y < 1 || e.z < 1) throw FormatError(file, "metadata " + name, "dimensions must be positive");
  return e;
}

}  // namespace

std::string_view ids_mode_name(IdsMode m) { return m == IdsMode::blocks ? "blocks" : "fixed"; }

IdsMode parse_ids_mode(std::string_view name) {
  if (name == "blocks") return IdsMode::blocks;
  if (name == "fixed") return IdsMode::fixed;
  throw Error("ids mode: expected blocks or fixed, got '" + std::string(name) + "'");
}

// ---------------------------------------------------------------------------------------------
// Graph bitstream

std::vector<std::byte> write_graph_bitstream(const MixtureGraph& g, bool fractional, Extent resolution) {
  const std::uint64_t nodes = g.node_count();
  if (nodes > std::numeric_limits<std::uint32_t>::max()) throw Error("mixture graph: more than 2^32 - 1 nodes");
  const int bpn = ceil_log2(nodes);
  const int qb = g.codebook.bits;
  if (qb < 1 || qb > 16) throw Error("mixture graph: codebook bits must be 1..16");
  if (g.codebook.value.size() != (std::size_t(1) << qb) || g.codebook.sigma.size() != g.codebook.value.size())
    throw Error("mixture graph: codebook must have 2^bits values and sigmas");
  double smax = 0.0;
  for (double s : g.codebook.sigma) smax = std::max(smax, std::isfinite(s) ? s : 0.0);
  const float sigma_max = float(smax);
  BitWriter w;
  w.put(g.num_sources, 32);                                    // (1)
  w.put(fractional ? 1 : 0, 1);                                // (2)
  w.put(std::uint64_t(bpn - 1), 6);                            // (3) bits per node - 1
  w.put(std::bit_cast<std::uint32_t>(sigma_max), 32);          // (4) IEEE float
  w.put(std::uint64_t(resolution.x), 32);                      // (5)
  w.put(std::uint64_t(resolution.y), 32);
  w.put(std::uint64_t(resolution.z), 32);
  w.put(std::uint64_t(qb - 1), 4);                             // (6) bitrate - 1
  w.put(g.codebook.layout == WeightBins::uniform ? 1 : 0, 1);  // (6b) deviation: bin layout
  w.put(g.nodes.size(), bpn);                                  // (7)
  for (const InternalNode& n : g.nodes) {                      // (B)
    w.put(n.a, bpn);
    w.put(n.b, bpn);
    w.put(n.bin, qb);
  }
  for (std::size_t i = 0; i < g.codebook.value.size(); ++i) {  // (C)
    const double v = std::clamp(g.codebook.value[i], 0.0, 1.0);
    w.put(std::min<std::uint64_t>(kCodeMax, std::uint64_t(std::llround(v * double(1u << kCodeBits)))), kCodeBits);
    const double s = std::isfinite(g.codebook.sigma[i]) ? g.codebook.sigma[i] : 0.0;
    // Rounded up: a decoded sigma never claims more precision than the encoder measured.
    const std::uint64_t qs =
        sigma_max > 0.0f ? std::min<std::uint64_t>(kCodeMax, std::uint64_t(std::ceil(s / double(sigma_max) * kCodeMax))) : 0;
    w.put(qs, kCodeBits);
  }
  return w.take();
}

MixtureGraph read_graph_bitstream(std::span<const std::byte> bytes, const std::string& file, GraphHeader* out_header) {
  BitReader r(bytes, file, "mixture_graph ");
  GraphHeader h;
  h.num_sources = std::uint32_t(r.get(32, "#sources"));
  h.fractional = r.get(1, "fractional flag") != 0;
  h.bits_per_node = int(r.get(6, "bits per node")) + 1;
  h.sigma_max = std::bit_cast<float>(std::uint32_t(r.get(32, "sigma max")));
  h.resolution.x = std::int64_t(r.get(32, "resolution"));
  h.resolution.y = std::int64_t(r.get(32, "resolution"));
  h.resolution.z = std::int64_t(r.get(32, "resolution"));
  h.quant_bits = int(r.get(4, "quantization bitrate")) + 1;
  h.layout = r.get(1, "bin layout") ? WeightBins::uniform : WeightBins::symmetric;
  if (h.num_sources == 0) throw FormatError(file, "mixture_graph #sources", "must be at least 1");
  if (h.bits_per_node > 32) throw FormatError(file, "mixture_graph bits per node", "must be at most 32, got " + std::to_string(h.bits_per_node));
  if (!std::isfinite(h.sigma_max) || h.sigma_max < 0.0f) throw FormatError(file, "mixture_graph sigma max", "must be finite and >= 0");
  if (h.resolution.x < 1 || h.resolution.y < 1 || h.resolution.z < 1)
    throw FormatError(file, "mixture_graph resolution", "dimensions must be positive");
  h.internal_nodes = r.get(h.bits_per_node, "#internal nodes");
  const std::uint64_t nodes = std::uint64_t(h.num_sources) + h.internal_nodes;
  if (nodes > (std::uint64_t(1) << h.bits_per_node) || nodes > std::numeric_limits<std::uint32_t>::max())
    throw FormatError(file, "mixture_graph #internal nodes",
                      std::to_string(nodes) + " nodes do not fit " + std::to_string(h.bits_per_node) + " bits per node");
  const std::uint64_t bins = std::uint64_t(1) << h.quant_bits;
  const std::uint64_t need = r.position() + h.internal_nodes * std::uint64_t(2 * h.bits_per_node + h.quant_bits) +
                             bins * 2 * kCodeBits;
  if ((need + 7) / 8 != bytes.size())
    throw FormatError(file, "mixture_graph size",
                      "expected " + std::to_string((need + 7) / 8) + " bytes for " + std::to_string(h.internal_nodes) +
                          " internal nodes, found " + std::to_string(bytes.size()));
  MixtureGraph g;
  g.num_sources = h.num_sources;
  g.nodes.resize(std::size_t(h.internal_nodes));
  for (std::uint64_t i = 0; i < h.internal_nodes; ++i) {
    InternalNode& n = g.nodes[std::size_t(i)];
    n.a = std::uint32_t(r.get(h.bits_per_node, "node a"));
    n.b = std::uint32_t(r.get(h.bits_per_node, "node b"));
    n.bin = std::uint32_t(r.get(h.quant_bits, "node bin"));
    const std::uint64_t id = h.num_sources + i;
    if (n.a >= id || n.b >= id || n.a == n.b)
      throw FormatError(file, "mixture_graph node " + std::to_string(id),
                        "predecessors (" + std::to_string(n.a) + ", " + std::to_string(n.b) +
                            ") must be distinct earlier nodes");
  }
  g.codebook.bits = h.quant_bits;
  g.codebook.layout = h.layout;
  g.codebook.value.resize(std::size_t(bins));
  g.codebook.sigma.resize(std::size_t(bins));
  g.codebook.uses.assign(std::size_t(bins), 0);
  for (std::uint64_t i = 0; i < bins; ++i) {
    const std::uint64_t qv = r.get(kCodeBits, "codebook value");
    const std::uint64_t qs = r.get(kCodeBits, "codebook sigma");
    g.codebook.value[std::size_t(i)] = double(qv) / double(1u << kCodeBits);
    // The stored value is the code rounded to 2^-20: a weight error of up to 2^-21 that even a
    // bin of exact weights (sigma 0) carries, taken as uniform, variance (2^-21)^2 / 3.
    const double stored_sigma = double(qs) / double(kCodeMax) * double(h.sigma_max);
    g.codebook.sigma[std::size_t(i)] = std::sqrt(stored_sigma * stored_sigma + kCodeRoundingVariance);
  }
  if (out_header) *out_header = h;
  return g;
}

// ---------------------------------------------------------------------------------------------
// Encoding

namespace {

// Share of level-0 voxels whose original label is 0 (Table 2's "background"); 0 when absent.
double background_fraction(const MipLevel& level0, const LabelMap& map) {
  const std::optional<std::uint32_t> zero = map.id_of(0);
  if (!zero || level0.ids.empty()) return 0.0;
  const auto n = std::count(level0.ids.begin(), level0.ids.end(), *zero);
  return double(n) / double(level0.ids.size());
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
      writer.add_section(level_section(int(l)), bytes);
      rep.ids_bytes.push_back(bytes.size());
      levels.push_back({{"dims", extent_json(lv.dims)}, {"ids_bytes", bytes.size()}});
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
                      {"mixture_graph_version", kFormatVersion},
                      {"source",
                       {{"dims", extent_json(labels.dims())},
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

// ---------------------------------------------------------------------------------------------
// Reading

EncodedLabels::~EncodedLabels() = default;

EncodedLabels::EncodedLabels(const std::filesystem::path& path)
    : EncodedLabels(std::make_unique<store::ContainerReader>(path)) {}

EncodedLabels::EncodedLabels(std::unique_ptr<store::ContainerReader> reader)
    : path_(reader->path()), reader_(std::move(reader)) {
  const std::string file = path_.string();
  const nlohmann::json& m = reader_->metadata();
  const std::string codec = m.is_object() && m.contains("codec") && m["codec"].is_string() ? m["codec"].get<std::string>() : "";
  if (codec != kMixtureCodecName)
    throw FormatError(file, "metadata codec", "expected \"mixture-graph\" (a label file from `strata labels encode`), got \"" + codec + "\"");
  const int version = field<int>(m, "mixture_graph_version", file);
  if (version != kFormatVersion)
    throw FormatError(file, "metadata mixture_graph_version", "unsupported version " + std::to_string(version));
  const nlohmann::json& src = m.contains("source") ? m["source"] : nlohmann::json();
  if (!src.is_object()) throw FormatError(file, "metadata source", "missing");
  const Extent dims = meta_extent(src.value("dims", nlohmann::json()), file, "source.dims");
  DType dtype;
  try {
    dtype = parse_dtype(field<std::string>(src, "dtype", file, "source"), "source.dtype");
  } catch (const FormatError&) {
    throw;
  } catch (const Error& e) {
    throw FormatError(file, "metadata source.dtype", e.what());
  }
  if (src.contains("spacing")) {
    const auto& s = src["spacing"];
    if (!s.is_array() || s.size() != 3 || !s[0].is_number() || !s[1].is_number() || !s[2].is_number())
      throw FormatError(file, "metadata source.spacing", "expected [sx, sy, sz]");
    spacing_ = {s[0].get<double>(), s[1].get<double>(), s[2].get<double>()};
  }
  const std::string ids = field<std::string>(m, "ids", file);
  try {
    ids_mode_ = parse_ids_mode(ids);
  } catch (const Error& e) {
    throw FormatError(file, "metadata ids", e.what());
  }

  const std::string comp = m.contains("ids_compression") ? field<std::string>(m, "ids_compression", file) : "none";
  if (comp != "none" && comp != "zstd") throw FormatError(file, "metadata ids_compression", "expected none or zstd, got " + comp);
  ids_zstd_ = comp == "zstd";

  // Graph.
  graph_ = read_graph_bitstream(reader_->section("mixture_graph"), file, &header_);
  if (header_.resolution != dims)
    throw FormatError(file, "mixture_graph resolution", "does not match metadata source.dims");
  if (field<int>(m, "bits", file) != header_.quant_bits)
    throw FormatError(file, "metadata bits", "does not match the bitstream's quantization bitrate " + std::to_string(header_.quant_bits));

  // Label map.
  {
    const auto section = reader_->section("label_map");
    ByteReader lm(section, file);
    const std::uint64_t n = lm.get<std::uint32_t>("section label_map");
    if (lm.remaining() != 8 * n)
      throw FormatError(file, "section label_map", "size " + std::to_string(section.size()) + " does not hold " + std::to_string(n) + " values");
    if (n != graph_.num_sources)
      throw FormatError(file, "section label_map", std::to_string(n) + " labels but the graph has " +
                                                       std::to_string(graph_.num_sources) + " sources");
    std::vector<std::int64_t> values(n);
    for (std::int64_t& v : values) v = lm.get<std::int64_t>("section label_map");
    try {
      label_map_ = LabelMap(dtype, std::move(values));
    } catch (const Error& e) {
      throw FormatError(file, "section label_map", e.what());
    }
  }

  // Levels.
  const std::vector<Extent> expect = mip_level_dims(dims);
  const auto& lv = m.contains("levels") ? m["levels"] : nlohmann::json();
  if (!lv.is_array() || lv.size() != expect.size())
    throw FormatError(file, "metadata levels", "expected " + std::to_string(expect.size()) + " levels for dims " + extent_json(dims).dump());
  for (std::size_t l = 0; l < expect.size(); ++l) {
    const std::string name = "levels[" + std::to_string(l) + "].dims";
    if (meta_extent(lv[l].value("dims", nlohmann::json()), file, name) != expect[l])
      throw FormatError(file, "metadata " + name, "expected " + extent_json(expect[l]).dump());
    const std::string sec = level_section(int(l));
    std::span<const std::byte> bytes = reader_->section(sec);
    std::vector<std::byte> inflated;
    if (ids_zstd_) {
      // Either layout needs at most ~8 bytes per voxel plus headers.
      const std::uint64_t limit = 16 * std::uint64_t(expect[l].voxel_count()) + (1u << 20);
      store::zstd_decompress(bytes, limit, inflated, file, "section " + sec);
      bytes = inflated;
    }
    Extent got;
    try {
      if (ids_mode_ == IdsMode::fixed) {
        fixed_.push_back(FixedRateIds::deserialize(bytes));
        got = fixed_.back().dims();
        if (fixed_.back().min_id() >= graph_.node_count())
          throw Error("minimum id " + std::to_string(fixed_.back().min_id()) + " is not a node");
      } else {
        blocks_.push_back(BlockPaletteIds::deserialize(bytes));
        got = blocks_.back().dims();
      }
    } catch (const Error& e) {
      throw FormatError(file, "section " + sec, e.what());
    }
    if (got != expect[l]) throw FormatError(file, "section " + sec, "dims do not match the level's " + extent_json(expect[l]).dump());
  }
  level_dims_ = expect;
  // Every stored id must name a node (level 0: a source), so node_at() results can index the
  // graph's tables safely. One pass over the ids, 8 slices (one block row) at a time.
  for (int l = 0; l < level_count(); ++l) {
    const Extent d = level_dims_[std::size_t(l)];
    const std::uint64_t limit = l == 0 ? graph_.num_sources : graph_.node_count();
    std::vector<std::uint32_t> ids;
    for (std::int64_t z0 = 0; z0 < d.z; z0 += BlockPaletteIds::kBlock) {
      const Box box{{0, 0, z0}, {d.x, d.y, std::min(d.z, z0 + BlockPaletteIds::kBlock)}};
      ids.resize(std::size_t(box.voxel_count()));
      decode_box(l, box, ids);
      const std::uint32_t hi = *std::max_element(ids.begin(), ids.end());
      if (hi >= limit)
        throw FormatError(file, "section " + level_section(l),
                          "node id " + std::to_string(hi) + " is not below " + std::to_string(limit) +
                              (l == 0 ? " (the number of sources)" : " (the number of nodes)"));
    }
  }
  schedule_ = make_schedule(graph_);
}

const nlohmann::json& EncodedLabels::metadata() const { return reader_->metadata(); }

Extent EncodedLabels::level_dims(int level) const {
  if (level < 0 || level >= level_count())
    throw Error(path_.string() + ": level " + std::to_string(level) + " is not in 0.." + std::to_string(level_count() - 1));
  return level_dims_[std::size_t(level)];
}

std::uint32_t EncodedLabels::node_at(int level, std::int64_t x, std::int64_t y, std::int64_t z) const {
  return ids_mode_ == IdsMode::fixed ? fixed_[std::size_t(level)].at(x, y, z) : blocks_[std::size_t(level)].at(x, y, z);
}

void EncodedLabels::decode_box(int level, const Box& box, std::span<std::uint32_t> out) const {
  const Extent d = level_dims(level);
  if (box.lo.x < 0 || box.lo.y < 0 || box.lo.z < 0 || box.hi.x > d.x || box.hi.y > d.y || box.hi.z > d.z)
    throw Error(path_.string() + ": box is outside level " + std::to_string(level));
  if (out.size() != std::size_t(box.voxel_count())) throw Error("decode_box: output size does not match the box");
  if (ids_mode_ == IdsMode::blocks) {
    blocks_[std::size_t(level)].decode_box(box, out);
    return;
  }
  const FixedRateIds& f = fixed_[std::size_t(level)];
  std::size_t i = 0;
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
      for (std::int64_t x = box.lo.x; x < box.hi.x; ++x) out[i++] = f.at(x, y, z);
}

std::vector<std::uint32_t> EncodedLabels::level_ids(int level) const {
  const Extent d = level_dims(level);
  std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()));
  decode_box(level, Box::whole(d), ids);  // ids were range-checked when the file was opened
  return ids;
}

Spacing EncodedLabels::level_spacing(int level) const {
  const double s = std::ldexp(1.0, level);
  return {spacing_.x * s, spacing_.y * s, spacing_.z * s};
}

const MixtureLookup& EncodedLabels::lookup() const {
  // First-order (linear) error propagation: Eq. 18 as printed gives a component of weight 1 - w an
  // uncertainty of sqrt(2)(1 - w) dw / w, which swamps query sigmas for small w (see lookup.hpp).
  std::call_once(lookup_once_, [this] {
    lookup_ = std::make_unique<MixtureLookup>(MixtureLookup::build(graph_, schedule_, ErrorModel::linear));
  });
  return *lookup_;
}

Volume EncodedLabels::decode_level0() const {
  return label_map_.decode(level_ids(0), level_dims_[0], spacing_);
}

Volume EncodedLabels::dominant_labels(int level) const {
  std::vector<std::uint32_t> ids = level_ids(level);
  const MixtureLookup& lut = lookup();
  std::vector<std::uint32_t> dominant(std::size_t(graph_.node_count()));
  for (std::uint32_t n = 0; n < dominant.size(); ++n) {
    const auto ix = lut.index(n);
    const auto mu = lut.mean_weights(n);
    std::size_t best = 0;
    for (std::size_t k = 1; k < ix.size(); ++k)
      if (mu[k] > mu[best]) best = k;  // index ascending: ties keep the smaller label
    dominant[n] = ix.empty() ? 0 : ix[best];
  }
  for (auto& id : ids) id = dominant[id];
  return label_map_.decode(ids, level_dims_[std::size_t(level)], level_spacing(level));
}

Volume EncodedLabels::label_fraction(int level, std::int64_t label_value) const {
  const auto source = label_map_.id_of(label_value);
  if (!source) throw Error(path_.string() + ": label " + std::to_string(label_value) + " does not occur in the volume");
  const std::vector<std::uint32_t> ids = level_ids(level);
  std::vector<float> indicator(graph_.num_sources, 0.0f);
  indicator[*source] = 1.0f;
  const std::vector<float> frac = propagate_palette(graph_, schedule_, indicator, 1);
  Volume out(level_dims_[std::size_t(level)], DType::f32, level_spacing(level));
  auto s = out.samples<float>();
  for (std::size_t i = 0; i < ids.size(); ++i) s[i] = frac[ids[i]];
  return out;
}

}  // namespace strata::mixture
