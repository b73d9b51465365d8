// Reading a Mixture Graph label file: EncodedLabels validates the metadata, the graph bitstream,
// the label map and every level's node ids, then serves node ids, labels and label fractions.
// Layout: docs/format.md, "Codec mixture-graph"; the writer is encode_labels.cpp.
#include "strata/mixture/encoded_labels.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "mixture/encoded_labels_format.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/mixture/palette.hpp"
#include "strata/store/container.hpp"
#include "strata/store/metadata_json.hpp"
#include "strata/store/geometry_json.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::mixture {

namespace {

using store::json_member;
using store::MetadataField;

Extent meta_extent(const nlohmann::json& j, const MetadataField& field) {
  const auto v = store::json_integers(j, 3, field, 1, INT32_MAX);
  return {v[0], v[1], v[2]};
}

}  // namespace

std::string_view ids_mode_name(IdsMode m) { return m == IdsMode::blocks ? "blocks" : "fixed"; }

IdsMode parse_ids_mode(std::string_view name) {
  if (name == "blocks") return IdsMode::blocks;
  if (name == "fixed") return IdsMode::fixed;
  throw Error("ids mode: expected blocks or fixed, got '" + std::string(name) + "'");
}

EncodedLabels::~EncodedLabels() = default;

EncodedLabels::EncodedLabels(const std::filesystem::path& path)
    : EncodedLabels(std::make_unique<store::ContainerReader>(path)) {}

EncodedLabels::EncodedLabels(std::unique_ptr<store::ContainerReader> reader)
    : reader_(std::move(reader)) {
  const std::string file = reader_->name();
  const nlohmann::json& m = reader_->metadata();
  const MetadataField meta{file, "metadata"};
  const std::string codec = m.is_object() && m.contains("codec") && m["codec"].is_string() ? m["codec"].get<std::string>() : "";
  if (codec != kMixtureCodecName)
    throw FormatError(file, "metadata.codec", "expected \"mixture-graph\" (a label file from `strata labels encode`), got " +
                                                  (m.contains("codec") ? store::json_excerpt(m["codec"]) : std::string("none")));
  store::json_integer(json_member(m, "mixture_graph_version", meta), meta / "mixture_graph_version", detail::kFormatVersion,
                      detail::kFormatVersion);
  const MetadataField src_field = meta / "source";
  const nlohmann::json& src = store::json_object(json_member(m, "source", meta), src_field);
  const Extent dims = meta_extent(json_member(src, "dims", src_field), src_field / "dims");
  DType dtype;
  const std::string dtype_text = store::json_string(json_member(src, "dtype", src_field), src_field / "dtype");
  try {
    dtype = parse_dtype(dtype_text, "metadata.source.dtype");
  } catch (const Error&) {
    (src_field / "dtype").fail("unknown sample type \"" + dtype_text + "\" (expected u8, i8, u16, i16, u32, i32, u64 or i64)");
  }
  if (!dtype_is_integer(dtype)) (src_field / "dtype").fail("a label volume has an integer sample type, got " + dtype_text);
  if (src.contains("spacing")) {
    const auto s = store::json_positive_numbers(src["spacing"], 3, src_field / "spacing");
    spacing_ = {s[0], s[1], s[2]};
  }
  geometry_ = store::geometry_from_json(src, src_field);
  const std::string ids = store::json_string(json_member(m, "ids", meta), meta / "ids");
  try {
    ids_mode_ = parse_ids_mode(ids);
  } catch (const Error&) {
    (meta / "ids").fail("expected \"blocks\" or \"fixed\", got \"" + ids + "\"");
  }

  const std::string comp = m.contains("ids_compression") ? store::json_string(m["ids_compression"], meta / "ids_compression") : "none";
  if (comp != "none" && comp != "zstd") (meta / "ids_compression").fail("expected \"none\" or \"zstd\", got \"" + comp + "\"");
  ids_zstd_ = comp == "zstd";

  // Graph.
  const io::SharedBytes graph = reader_->section("mixture_graph");
  graph_ = read_graph_bitstream(graph, file, &header_);
  if (header_.resolution != dims)
    throw FormatError(file, "section mixture_graph", "resolution " + detail::extent_json(header_.resolution).dump() +
                                                         " does not match metadata.source.dims " + detail::extent_json(dims).dump());
  const auto bits = store::json_integer(json_member(m, "bits", meta), meta / "bits", 1, 16);
  if (bits != header_.quant_bits)
    (meta / "bits").fail(std::to_string(bits) + " does not match the bitstream's quantization bitrate " + std::to_string(header_.quant_bits));
  if (m.contains("bins")) {
    const std::string bins = store::json_string(m["bins"], meta / "bins");
    if (bins != weight_bins_name(header_.layout))
      (meta / "bins").fail("\"" + bins + "\" does not match the bitstream's bin layout \"" + std::string(weight_bins_name(header_.layout)) + "\"");
  }

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
  const MetadataField lv_field = meta / "levels";
  const auto& lv = json_member(m, "levels", meta);
  if (!lv.is_array() || lv.size() != expect.size())
    lv_field.fail("expected " + std::to_string(expect.size()) + " levels for dims " + detail::extent_json(dims).dump() + ", got " +
                  (lv.is_array() ? std::to_string(lv.size()) : store::json_excerpt(lv)));
  for (std::size_t l = 0; l < expect.size(); ++l) {
    const MetadataField level = lv_field[l];
    if (meta_extent(json_member(lv[l], "dims", level), level / "dims") != expect[l])
      (level / "dims").fail("expected " + detail::extent_json(expect[l]).dump() + " for source.dims " + detail::extent_json(dims).dump() +
                            ", got " + store::json_excerpt(lv[l]["dims"]));
    const std::string sec = detail::level_section(int(l));
    const io::SharedBytes stored = reader_->section(sec);
    std::span<const std::byte> bytes = stored;
    if (lv[l].contains("ids_bytes") && store::json_unsigned(lv[l]["ids_bytes"], level / "ids_bytes") != bytes.size())
      (level / "ids_bytes").fail("says " + std::to_string(lv[l]["ids_bytes"].get<std::uint64_t>()) + " but section " + sec + " holds " +
                                 std::to_string(bytes.size()) + " bytes");
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
    if (got != expect[l]) throw FormatError(file, "section " + sec, "dims do not match the level's " + detail::extent_json(expect[l]).dump());
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
        throw FormatError(file, "section " + detail::level_section(l),
                          "node id " + std::to_string(hi) + " is not below " + std::to_string(limit) +
                              (l == 0 ? " (the number of sources)" : " (the number of nodes)"));
    }
  }
  schedule_ = make_schedule(graph_);
}

const nlohmann::json& EncodedLabels::metadata() const { return reader_->metadata(); }
const std::filesystem::path& EncodedLabels::path() const { return reader_->path(); }
const std::string& EncodedLabels::name() const { return reader_->name(); }

bool EncodedLabels::has_normals() const { return reader_->has_section("normals"); }

std::unique_ptr<EncodedLabels> EncodedLabels::open_normals() const {
  if (!has_normals()) throw FormatError(name(), "section normals", "missing: encode with `strata labels encode --normals`");
  auto normals = std::make_unique<EncodedLabels>(
      std::make_unique<store::ContainerReader>(*reader_, "normals", name() + " (normals)"));
  // Its levels must line up voxel for voxel with the labels' (the renderer samples both at once).
  if (normals->level_dims_ != level_dims_)
    throw FormatError(name(), "section normals",
                      fmt::format("its levels do not match the labels' ({} against {} levels, level 0 {} against {})",
                                  normals->level_count(), level_count(), normals->level_dims(0).to_string(),
                                  level_dims(0).to_string()));
  // Codes are 0..511 (label_normals.hpp).
  const auto values = normals->label_map().values();
  if (!values.empty() && (values.front() < 0 || values.back() >= kNormalCodes))
    throw FormatError(name(), "section normals", fmt::format("holds code {}; expected 0..{}", values.back() >= kNormalCodes ? values.back() : values.front(), kNormalCodes - 1));
  return normals;
}

Extent EncodedLabels::level_dims(int level) const {
  if (level < 0 || level >= level_count())
    throw Error(name() + ": level " + std::to_string(level) + " is not in 0.." + std::to_string(level_count() - 1));
  return level_dims_[std::size_t(level)];
}

std::uint32_t EncodedLabels::node_at(int level, std::int64_t x, std::int64_t y, std::int64_t z) const {
  return ids_mode_ == IdsMode::fixed ? fixed_[std::size_t(level)].at(x, y, z) : blocks_[std::size_t(level)].at(x, y, z);
}

void EncodedLabels::decode_box(int level, const Box& box, std::span<std::uint32_t> out) const {
  const Extent d = level_dims(level);
  if (box.lo.x < 0 || box.lo.y < 0 || box.lo.z < 0 || box.hi.x > d.x || box.hi.y > d.y || box.hi.z > d.z)
    throw Error(name() + ": box is outside level " + std::to_string(level));
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

Volume EncodedLabels::decode_level0() const { return LevelDecoder(*this, 0).slices(0, level_dims_[0].z); }

std::vector<std::uint32_t> EncodedLabels::dominant_sources() const {
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
  return dominant;
}

std::vector<float> EncodedLabels::label_fractions(std::int64_t label_value) const {
  const auto source = label_map_.id_of(label_value);
  if (!source) throw Error(name() + ": label " + std::to_string(label_value) + " does not occur in the volume");
  std::vector<float> indicator(graph_.num_sources, 0.0f);
  indicator[*source] = 1.0f;
  return propagate_palette(graph_, schedule_, indicator, 1);
}

Volume EncodedLabels::dominant_labels(int level) const {
  const LevelDecoder decoder(*this, level);
  return decoder.slices(0, decoder.info().dims.z);
}

Volume EncodedLabels::label_fraction(int level, std::int64_t label_value) const {
  const LevelDecoder decoder(*this, level, label_value);
  return decoder.slices(0, decoder.info().dims.z);
}

// ---------------------------------------------------------------------------------------------
// LevelDecoder

LevelDecoder::LevelDecoder(const EncodedLabels& labels, int level, std::optional<std::int64_t> label)
    : labels_(labels), level_(level) {
  if (level < 0 || level >= labels.level_count())
    throw Error(labels.name() + ": level " + std::to_string(level) + " is not in 0.." +
                std::to_string(labels.level_count() - 1));
  info_.dims = labels.level_dims(level);
  info_.spacing = labels.level_spacing(level);
  info_.geometry = level_geometry(labels.geometry(), labels.spacing(), level);
  info_.dtype = labels.label_map().dtype();
  if (label) {
    fraction_ = labels.label_fractions(*label);
    info_.dtype = DType::f32;
  } else if (level > 0) {
    dominant_ = labels.dominant_sources();  // level 0's node ids are its source ids
  }
}

Volume LevelDecoder::slices(std::int64_t z0, std::int64_t z1) const {
  const Extent& d = info_.dims;
  if (z0 < 0 || z1 <= z0 || z1 > d.z)
    throw Error(labels_.name() + ": slices [" + std::to_string(z0) + ", " + std::to_string(z1) +
                ") are not within level " + std::to_string(level_) + " of dims " + d.to_string());
  return box(Box{{0, 0, z0}, {d.x, d.y, z1}});
}

Volume LevelDecoder::box(const Box& box) const {
  if (box.empty() || !Box::whole(info_.dims).contains(box))
    throw Error(labels_.name() + ": box " + box.to_string() + " is not within level " + std::to_string(level_) +
                " of dims " + info_.dims.to_string());
  const Extent size = box.size();
  std::vector<std::uint32_t> ids(std::size_t(size.voxel_count()));
  labels_.decode_box(level_, box, ids);  // ids were range-checked at open
  if (!fraction_.empty()) {
    Volume out(size, DType::f32, info_.spacing);
    auto s = out.samples<float>();
    for (std::size_t i = 0; i < ids.size(); ++i) s[i] = fraction_[ids[i]];
    return out;
  }
  if (!dominant_.empty())
    for (auto& id : ids) id = dominant_[id];
  return labels_.label_map().decode(ids, size, info_.spacing);
}

}  // namespace strata::mixture
