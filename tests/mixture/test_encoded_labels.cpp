// Mixture Graph storage in .strata files: graph bitstream, round trips for both id modes,
// coarse levels against the histogram mipmap, corruption and truncation.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <optional>
#include <fstream>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/store/container.hpp"
#include "support/test_support.hpp"

namespace strata::mixture {
namespace {

Volume make_labels(gen::Kind kind, Extent dims, std::int64_t count) {
  gen::Params p;
  p.kind = kind;
  p.dims = dims;
  p.count = count;
  return gen::generate(p);
}

using strata::test::error_of;

// Every level's decoded mixture (through the stored graph) against the exact histogram.
double max_level_error(const EncodedLabels& e, const HistogramMipmap& h, int level) {
  const MixtureLookup& lut = e.lookup();
  const Extent d = e.level_dims(level);
  double worst = 0.0;
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const SparseMixture m = h.mixture(level, x, y, z);
        const std::uint32_t node = e.node_at(level, x, y, z);
        std::vector<double> dense(e.graph().num_sources, 0.0);
        for (const SparseEntry& en : m.entries()) dense[en.index] += en.weight;
        const auto ix = lut.index(node);
        const auto mu = lut.mean_weights(node);
        for (std::size_t k = 0; k < ix.size(); ++k) dense[ix[k]] -= mu[k];
        double l1 = 0.0;
        for (double v : dense) l1 += std::abs(v);
        worst = std::max(worst, l1);
      }
  return worst;
}

void round_trip(const Volume& labels, IdsMode mode, const std::string& name, int zstd = 9) {
  test::TempDir dir;
  const auto file = dir / (name + ".strata");
  EncodeOptions o;
  o.ids = mode;
  o.ids_zstd = zstd;
  const EncodeReport r = encode_labels(labels, file, o);
  ASSERT_TRUE(r.max_l1.has_value());
  EXPECT_EQ(r.file_bytes, std::filesystem::file_size(file));
  EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp"));

  const EncodedLabels e(file);
  EXPECT_EQ(e.ids_mode(), mode);
  EXPECT_EQ(e.ids_compressed(), zstd > 0);
  EXPECT_EQ(e.graph().node_count(), r.nodes);
  EXPECT_EQ(e.schedule().depth, r.depth);
  const Volume decoded = e.decode_level0();
  EXPECT_EQ(decoded.dtype(), labels.dtype());
  EXPECT_TRUE(decoded == labels) << name << " level 0 is not bit-exact";

  // Coarser levels: within the measured (quantisation) error of the stored graph.
  LabelMap map;
  const HistogramMipmap h = HistogramMipmap::from_labels(labels, &map);
  EXPECT_EQ(map, e.label_map());
  ASSERT_EQ(e.level_count(), h.level_count());
  for (int l = 0; l < e.level_count(); ++l) {
    const double err = max_level_error(e, h, l);
    EXPECT_LE(err, *r.max_l1 + 1e-9) << name << " level " << l;
    if (l == 0) {
      EXPECT_EQ(err, 0.0);
    }
  }
  EXPECT_LT(*r.max_l1, 0.01);

  // decode_box agrees with node_at.
  const int l = std::min(1, e.level_count() - 1);
  const Extent d = e.level_dims(l);
  const Box box{{d.x / 4, d.y / 3, 0}, {d.x, d.y, std::max<std::int64_t>(1, d.z / 2)}};
  std::vector<std::uint32_t> ids(std::size_t(box.voxel_count()));
  e.decode_box(l, box, ids);
  std::size_t i = 0;
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
      for (std::int64_t x = box.lo.x; x < box.hi.x; ++x) ASSERT_EQ(ids[i++], e.node_at(l, x, y, z));

  // Dominant label and fractions at level 1.
  if (e.level_count() > 1) {
    const Volume dom = e.dominant_labels(1);
    EXPECT_EQ(dom.dtype(), labels.dtype());
    EXPECT_EQ(dom.dims(), e.level_dims(1));
    const std::int64_t label = map.value(0);
    const Volume frac = e.label_fraction(1, label);
    EXPECT_EQ(frac.dtype(), DType::f32);
    const auto fs = frac.samples<float>();
    const Extent d1 = e.level_dims(1);
    for (std::int64_t z = 0; z < d1.z; ++z)
      for (std::int64_t y = 0; y < d1.y; ++y)
        for (std::int64_t x = 0; x < d1.x; ++x) {
          const SparseMixture m = h.mixture(1, x, y, z);
          const double exact = m.weight(0);
          ASSERT_NEAR(fs[std::size_t((z * d1.y + y) * d1.x + x)], exact, *r.max_l1 + 1e-5);
        }
    EXPECT_NE(error_of([&] { (void)e.label_fraction(1, map.values().back() + 12345); }).find("label"), std::string::npos);
  }
  std::printf("[ %-8s ] %s: %llu nodes, depth %u, %.3f bits/voxel, max l1 %.5f\n", name.c_str(),
              std::string(ids_mode_name(mode)).c_str(), (unsigned long long)r.nodes, r.depth, r.bits_per_voxel, *r.max_l1);
}

TEST(MixtureEncodedLabels, GraphBitstreamRoundTrip) {
  MixtureGraph g;
  g.num_sources = 5;
  g.nodes = {{0, 1, 3}, {2, 5, 0}, {6, 3, 7}, {4, 7, 1}};
  g.codebook.bits = 3;
  g.codebook.layout = WeightBins::symmetric;
  for (int i = 0; i < 8; ++i) {
    g.codebook.value.push_back((i + 1) / 16.0);
    g.codebook.sigma.push_back(i * 0.001);
  }
  const auto bytes = write_graph_bitstream(g, false, {7, 8, 9});
  // Header 32+1+6+32+96+4+1 + #internal at 4 bits, 4 nodes x (2*4+3), 8 x 40 codebook bits.
  EXPECT_EQ(bytes.size(), (172u + 4 + 4 * 11 + 8 * 40 + 7) / 8);
  GraphHeader h;
  const MixtureGraph r = read_graph_bitstream(bytes, "mem", &h);
  EXPECT_EQ(h.bits_per_node, 4);
  EXPECT_EQ(h.resolution, (Extent{7, 8, 9}));
  EXPECT_EQ(h.internal_nodes, 4u);
  EXPECT_EQ(r.num_sources, 5u);
  EXPECT_EQ(r.nodes, g.nodes);
  for (int i = 0; i < 8; ++i) {
    EXPECT_NEAR(r.codebook.value[i], g.codebook.value[i], 1.0 / (1 << 20));
    // Sigma is stored rounded up (20 bits of sigma_max = 0.007) and the reader adds the
    // code's own rounding, uniform within +- 2^-21: never less than the encoder's sigma.
    const double rounding = std::ldexp(1.0, -21) / std::sqrt(3.0);
    EXPECT_GE(r.codebook.sigma[i], std::hypot(g.codebook.sigma[i], rounding) * (1.0 - 1e-7));
    EXPECT_LE(r.codebook.sigma[i], std::hypot(g.codebook.sigma[i] + 0.007 / ((1 << 20) - 1), rounding));
  }
  // Truncated, extended and cyclic streams are rejected.
  auto cut = bytes;
  cut.pop_back();
  EXPECT_NE(error_of([&] { read_graph_bitstream(cut, "mem"); }).find("mixture_graph"), std::string::npos);
  auto longer = bytes;
  longer.push_back(std::byte{0});
  EXPECT_NE(error_of([&] { read_graph_bitstream(longer, "mem"); }).find("size"), std::string::npos);
  MixtureGraph bad = g;
  bad.nodes[1].b = 7;  // node 6 referencing node 7 (later)
  EXPECT_NE(error_of([&] { read_graph_bitstream(write_graph_bitstream(bad, false, {1, 1, 1}), "mem"); }).find("node 6"),
            std::string::npos);
}

TEST(MixtureEncodedLabels, VoronoiRoundTripBothIdModes) {
  const Volume v = make_labels(gen::Kind::voronoi, {37, 30, 21}, 40);
  round_trip(v, IdsMode::blocks, "voronoi");
  round_trip(v, IdsMode::fixed, "voronoi");
  round_trip(v, IdsMode::blocks, "vor-raw", 0);  // ids sections stored without zstd
  round_trip(v, IdsMode::fixed, "vor-raw", 0);
}

TEST(MixtureEncodedLabels, FibresRoundTripBothIdModes) {
  const Volume v = make_labels(gen::Kind::fibres, {40, 33, 26}, 150);
  round_trip(v, IdsMode::blocks, "fibres");
  round_trip(v, IdsMode::fixed, "fibres");
}

// Slabs of every decoded kind (labels, dominant labels, fractions), concatenated in z, are the
// whole level: what `labels decode` writes slab by slab.
TEST(MixtureEncodedLabels, LevelDecoderSlabsMakeTheWholeLevel) {
  const Volume labels = make_labels(gen::Kind::fibres, {23, 19, 30}, 25);
  test::TempDir dir;
  const auto file = dir / "f.strata";
  encode_labels(labels, file);
  const EncodedLabels e(file);
  const std::int64_t some_label = e.label_map().value(1);
  for (const auto& [level, label] : std::vector<std::pair<int, std::optional<std::int64_t>>>{
           {0, std::nullopt}, {1, std::nullopt}, {2, std::nullopt}, {0, some_label}, {1, some_label}}) {
    const LevelDecoder decoder(e, level, label);
    const Volume whole = !label ? (level == 0 ? e.decode_level0() : e.dominant_labels(level))
                                : e.label_fraction(level, *label);
    EXPECT_EQ(decoder.info().dims, whole.dims());
    EXPECT_EQ(decoder.info().dtype, whole.dtype());
    const std::size_t slice = std::size_t(whole.dims().x * whole.dims().y) * dtype_size(whole.dtype());
    std::vector<std::byte> joined;
    for (std::int64_t z0 = 0; z0 < whole.dims().z; z0 += 4) {
      const Volume slab = decoder.slices(z0, std::min(whole.dims().z, z0 + 4));
      ASSERT_EQ(slab.byte_size(), std::size_t(slab.dims().z) * slice);
      joined.insert(joined.end(), slab.bytes(), slab.bytes() + slab.byte_size());
    }
    EXPECT_TRUE(std::equal(joined.begin(), joined.end(), whole.bytes(), whole.bytes() + whole.byte_size()))
        << "level " << level << (label ? " with a label" : "");
  }
  EXPECT_EQ(LevelDecoder(e, 0).slices(0, 30), labels);  // level 0 is the input, bit for bit
  const LevelDecoder l1(e, 1);
  EXPECT_NE(error_of([&] { (void)l1.slices(3, 3); }).find("not within level 1"), std::string::npos);
  EXPECT_NE(error_of([&] { (void)l1.slices(0, 16); }).find("not within level 1"), std::string::npos);
  EXPECT_NE(error_of([&] { LevelDecoder(e, e.level_count()); }).find("level"), std::string::npos);
  EXPECT_NE(error_of([&] { LevelDecoder(e, 1, e.label_map().values().back() + 7); }).find("does not occur"),
            std::string::npos);
}

TEST(MixtureEncodedLabels, KeepsDtypeAndSignedValues) {
  Volume v({9, 7, 5}, DType::i16);
  auto s = v.samples<std::int16_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::int16_t(i % 13 < 6 ? -300 : (i / 40) * 1000 - 2000);
  round_trip(v, IdsMode::blocks, "i16");
  Volume one({3, 2, 2}, DType::u8);  // a single label: no internal nodes
  for (auto& x : one.samples<std::uint8_t>()) x = 7;
  round_trip(one, IdsMode::fixed, "single");
}

// Table 2 columns of the report, on a volume whose mipmap is known by hand: 4x2x2 voxels, the
// left half label 0 (background), the right half labels 5 and 9 in alternating rows.
TEST(MixtureEncodedLabels, ReportDescribesTheMipmap) {
  Volume v({4, 2, 2}, DType::u8);
  auto s = v.samples<std::uint8_t>();
  for (std::int64_t z = 0; z < 2; ++z)
    for (std::int64_t y = 0; y < 2; ++y)
      for (std::int64_t x = 0; x < 4; ++x) s[std::size_t((z * 2 + y) * 4 + x)] = x < 2 ? 0 : (y == 0 ? 5 : 9);
  test::TempDir dir;
  const EncodeReport r = encode_labels(v, dir.path() / "r.strata");
  // Levels 4x2x2 (16 voxels, one label each), 2x1x1 (a pure 0 and a 5/9 mix), 1x1x1 (0/5/9).
  EXPECT_EQ(r.mip_levels, 3);
  EXPECT_EQ(r.mip_voxels, 19u);
  EXPECT_DOUBLE_EQ(r.nnz_per_voxel, (16.0 + 1.0 + 2.0 + 3.0) / 19.0);
  EXPECT_EQ(r.raw_histogram_bytes, 22u * 8u);
  EXPECT_DOUBLE_EQ(r.background_fraction, 0.5);
  EXPECT_EQ(r.level0_voxels, 16u);
}

TEST(MixtureEncodedLabels, GalaFibsemRoundTrip) {
  const auto path = test::shared_data("gala_fibsem_test_gt.nrrd");
  if (!path) GTEST_SKIP() << "gala_fibsem_test_gt.nrrd not available";
  const Volume labels = io::read_volume(*path);
  round_trip(labels, IdsMode::blocks, "gala");
  round_trip(labels, IdsMode::fixed, "gala");
}

TEST(MixtureEncodedLabels, CorruptionAndTruncationAreErrors) {
  test::TempDir dir;
  const auto file = dir / "v.strata";
  const Volume v = make_labels(gen::Kind::voronoi, {20, 18, 16}, 12);
  encode_labels(v, file);
  std::vector<char> bytes(std::filesystem::file_size(file));
  std::ifstream(file, std::ios::binary).read(bytes.data(), std::streamsize(bytes.size()));

  const store::ContainerReader reader(file);
  const nlohmann::json sections = reader.metadata()["sections"];
  for (const char* name : {"mixture_graph", "label_map", "ids_L0", "ids_L2"}) {
    std::vector<char> copy = bytes;
    const auto offset = sections[name]["offset"].get<std::uint64_t>();
    const auto size = sections[name]["size"].get<std::uint64_t>();
    copy[offset + size / 2] ^= 0x20;
    const auto bad = dir / (std::string(name) + ".strata");
    std::ofstream(bad, std::ios::binary).write(copy.data(), std::streamsize(copy.size()));
    const std::string msg = error_of([&] { EncodedLabels e(bad); });
    EXPECT_NE(msg.find(name), std::string::npos) << msg;
    EXPECT_NE(msg.find(bad.filename().string()), std::string::npos) << msg;
  }
  for (std::size_t keep : {bytes.size() - 1, bytes.size() / 2, std::size_t(10)}) {
    const auto cut = dir / "cut.strata";
    std::ofstream(cut, std::ios::binary).write(bytes.data(), std::streamsize(keep));
    EXPECT_NE(error_of([&] { EncodedLabels e(cut); }), "") << keep;
  }
  // Not a label file: a clear message about the codec.
  const auto other = dir / "other.strata";
  {
    store::ContainerWriter w(other);
    w.finish({{"codec", "ta"}});
  }
  EXPECT_NE(error_of([&] { EncodedLabels e(other); }).find("codec"), std::string::npos);
}

// Checksums are right but an id names no node: rejected at open, naming the section.
TEST(MixtureEncodedLabels, OutOfRangeIdsAreRejected) {
  test::TempDir dir;
  const auto good = dir / "good.strata";
  const Volume v = make_labels(gen::Kind::voronoi, {12, 10, 9}, 6);
  EncodeOptions o;
  o.ids = IdsMode::fixed;
  o.ids_zstd = 0;
  encode_labels(v, good, o);
  for (int level : {0, 1}) {
    const auto bad = dir / ("bad" + std::to_string(level) + ".strata");
    {
      const store::ContainerReader in(good);
      const EncodedLabels e(good);
      nlohmann::json meta = in.metadata();
      meta.erase("sections");
      store::ContainerWriter out(bad);
      for (const auto& [name, sec] : in.metadata()["sections"].items()) {
        if (name == "ids_L" + std::to_string(level)) {
          const Extent d = e.level_dims(level);
          std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()), level == 0 ? e.graph().num_sources
                                                                                  : std::uint32_t(e.graph().node_count()));
          out.add_section(name, FixedRateIds(ids, d).serialize());
        } else {
          const io::SharedBytes bytes = in.section(name);
          out.add_section(name, bytes);
        }
      }
      out.finish(meta);
    }
    const std::string msg = error_of([&] { EncodedLabels e(bad); });
    EXPECT_NE(msg.find("ids_L" + std::to_string(level)), std::string::npos) << msg;
  }
}

}  // namespace
}  // namespace strata::mixture
