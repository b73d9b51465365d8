// Sparse mixtures, the label id map and the histogram mipmap (checked against brute force).
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <random>

#include "strata/core/error.hpp"
#include "strata/mixture/histogram_mipmap.hpp"
#include "strata/mixture/label_map.hpp"
#include "strata/mixture/sparse_mixture.hpp"

namespace strata::mixture {
namespace {

TEST(MixtureSparseMixture, FromEntriesSortsMergesAndDropsZeros) {
  auto m = SparseMixture::from_entries({{5, 1.0}, {2, 0.5}, {5, 2.0}, {9, 0.0}, {1, 0.25}});
  ASSERT_EQ(m.nnz(), 3u);
  EXPECT_EQ(m[0], (SparseEntry{1, 0.25}));
  EXPECT_EQ(m[1], (SparseEntry{2, 0.5}));
  EXPECT_EQ(m[2], (SparseEntry{5, 3.0}));
  EXPECT_EQ(m.max_index(), 5u);
  EXPECT_DOUBLE_EQ(m.total(), 3.75);
  EXPECT_DOUBLE_EQ(m.weight(2), 0.5);
  EXPECT_DOUBLE_EQ(m.weight(3), 0.0);
  EXPECT_TRUE(m.contains(5));
  EXPECT_FALSE(m.contains(9));
  EXPECT_THROW(SparseMixture::from_entries({{1, -1.0}}), Error);
}

TEST(MixtureSparseMixture, NormalizeLerpDistanceDot) {
  auto a = SparseMixture::from_entries({{0, 1.0}, {1, 3.0}});
  a.normalize();
  EXPECT_DOUBLE_EQ(a.weight(0), 0.25);
  EXPECT_DOUBLE_EQ(a.total(), 1.0);
  const auto b = SparseMixture::unit(2);
  const auto l = SparseMixture::lerp(a, b, 0.5);
  ASSERT_EQ(l.nnz(), 3u);
  EXPECT_DOUBLE_EQ(l.weight(0), 0.125);
  EXPECT_DOUBLE_EQ(l.weight(1), 0.375);
  EXPECT_DOUBLE_EQ(l.weight(2), 0.5);
  EXPECT_DOUBLE_EQ(SparseMixture::l1_distance(a, b), 2.0);
  EXPECT_DOUBLE_EQ(SparseMixture::l1_distance(a, l), 0.125 + 0.375 + 0.5);
  const std::vector<double> x{4.0, 8.0, 16.0};
  EXPECT_DOUBLE_EQ(l.dot(x), 0.5 + 3.0 + 8.0);
}

template <class T>
Volume labels_volume(Extent d, std::vector<T> values, std::uint64_t seed) {
  Volume v(d, dtype_of<T>());
  std::mt19937_64 rng(seed);
  auto s = v.samples<T>();
  for (auto& x : s) x = values[rng() % values.size()];
  return v;
}

template <class T>
void check_label_roundtrip(std::vector<T> values) {
  const Volume v = labels_volume<T>({7, 5, 3}, values, 3);
  const SourceIds s = to_source_ids(v);
  std::vector<T> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  // Only the values that occur get ids, in ascending order.
  std::vector<std::int64_t> present;
  for (T x : v.samples<T>()) present.push_back(x);
  std::sort(present.begin(), present.end());
  present.erase(std::unique(present.begin(), present.end()), present.end());
  ASSERT_EQ(std::vector<std::int64_t>(s.map.values().begin(), s.map.values().end()), present);
  for (std::size_t i = 0; i < s.ids.size(); ++i) EXPECT_EQ(s.map.value(s.ids[i]), std::int64_t(v.samples<T>()[i]));
  const Volume back = s.map.decode(s.ids, s.dims);
  EXPECT_TRUE(back == v);
}

TEST(MixtureLabelMap, RoundTripEveryIntegerDtype) {
  check_label_roundtrip<std::uint8_t>({0, 7, 255, 3});
  check_label_roundtrip<std::int8_t>({-128, -1, 0, 127});
  check_label_roundtrip<std::uint16_t>({0, 65535, 1000, 17});
  check_label_roundtrip<std::int16_t>({-32768, 32767, 0, -5});
  check_label_roundtrip<std::uint32_t>({0, 4294967295u, 123456789u, 5u, 6u});
  check_label_roundtrip<std::int32_t>({-2147483647 - 1, 2147483647, 0, -77});
}

TEST(MixtureLabelMap, RejectsFloatAndBadIds) {
  Volume f({2, 2, 2}, DType::f32);
  EXPECT_THROW(to_source_ids(f), Error);
  LabelMap m(DType::u8, {1, 2});
  EXPECT_EQ(m.id_of(2), 1u);
  EXPECT_FALSE(m.id_of(3).has_value());
  std::vector<std::uint32_t> ids{0, 5};
  EXPECT_THROW(m.decode(ids, {2, 1, 1}), Error);
  EXPECT_THROW(LabelMap(DType::u8, {2, 1}), Error);
}

TEST(MixtureMipmap, LevelDims) {
  const auto d = mip_level_dims({5, 3, 1});
  ASSERT_EQ(d.size(), 4u);
  EXPECT_EQ(d[1], (Extent{3, 2, 1}));
  EXPECT_EQ(d[2], (Extent{2, 1, 1}));
  EXPECT_EQ(d[3], (Extent{1, 1, 1}));
  EXPECT_EQ(mip_level_dims({1, 1, 1}).size(), 1u);
}

// Brute force Eq. 4 with std::map histograms (double weights).
using Dense = std::map<std::uint32_t, double>;
std::vector<std::vector<Dense>> brute_force(Extent d, const std::vector<Dense>& level0) {
  std::vector<std::vector<Dense>> levels{level0};
  const auto dims = mip_level_dims(d);
  for (std::size_t l = 1; l < dims.size(); ++l) {
    const Extent P = dims[l], C = dims[l - 1];
    std::vector<Dense> out(std::size_t(P.voxel_count()));
    for (std::int64_t z = 0; z < P.z; ++z)
      for (std::int64_t y = 0; y < P.y; ++y)
        for (std::int64_t x = 0; x < P.x; ++x) {
          Dense sum;
          int n = 0;
          for (std::int64_t cz = 2 * z; cz < std::min(C.z, 2 * z + 2); ++cz)
            for (std::int64_t cy = 2 * y; cy < std::min(C.y, 2 * y + 2); ++cy)
              for (std::int64_t cx = 2 * x; cx < std::min(C.x, 2 * x + 2); ++cx) {
                ++n;
                for (auto [k, w] : levels[l - 1][std::size_t((cz * C.y + cy) * C.x + cx)]) sum[k] += w;
              }
          for (auto& [k, w] : sum) w /= n;
          out[std::size_t((z * P.y + y) * P.x + x)] = sum;
        }
    levels.push_back(std::move(out));
  }
  return levels;
}

void expect_matches(const HistogramMipmap& h, const std::vector<std::vector<Dense>>& ref) {
  ASSERT_EQ(std::size_t(h.level_count()), ref.size());
  for (int l = 0; l < h.level_count(); ++l) {
    const auto& L = h.level(l);
    for (std::int64_t z = 0; z < L.dims.z; ++z)
      for (std::int64_t y = 0; y < L.dims.y; ++y)
        for (std::int64_t x = 0; x < L.dims.x; ++x) {
          const Dense& r = ref[std::size_t(l)][L.index(x, y, z)];
          const SparseMixture m = h.mixture(l, x, y, z);
          ASSERT_EQ(m.nnz(), r.size()) << "level " << l << " voxel " << x << "," << y << "," << z;
          for (const auto& e : m.entries()) EXPECT_NEAR(e.weight, r.at(e.index), 1e-12);
          EXPECT_NEAR(m.total(), 1.0, 1e-12);
        }
  }
}

TEST(MixtureMipmap, MatchesBruteForceOnOddSizes) {
  for (Extent d : {Extent{7, 5, 3}, Extent{13, 9, 6}, Extent{1, 1, 9}, Extent{16, 16, 16}, Extent{3, 17, 2}}) {
    std::mt19937_64 rng(d.x * 100 + d.y * 10 + d.z);
    const std::uint32_t n = 6;
    std::vector<std::uint32_t> ids(std::size_t(d.voxel_count()));
    // Blocky labels so that coarse levels repeat mixtures.
    for (std::int64_t z = 0; z < d.z; ++z)
      for (std::int64_t y = 0; y < d.y; ++y)
        for (std::int64_t x = 0; x < d.x; ++x)
          ids[std::size_t((z * d.y + y) * d.x + x)] = (rng() % 5 == 0) ? std::uint32_t(rng() % n) : std::uint32_t((x / 3 + y / 2 + z) % n);
    std::vector<Dense> l0;
    for (auto id : ids) l0.push_back({{id, 1.0}});
    const auto ref = brute_force(d, l0);
    const HistogramMipmap h = HistogramMipmap::from_source_ids(d, ids, n);
    EXPECT_FALSE(h.fractional());
    EXPECT_TRUE(h.table().integral());
    // Level 0 ids are the source ids.
    EXPECT_EQ(h.level(0).ids, ids);
    expect_matches(h, ref);
    // Multiplicities add up to the voxel count over all levels; distinct entries really are.
    const MipmapStats st = h.stats();
    std::uint64_t voxels = 0;
    for (int l = 0; l < h.level_count(); ++l) voxels += h.level(l).ids.size();
    EXPECT_EQ(st.voxels, voxels);
    std::set<std::vector<std::pair<std::uint32_t, double>>> seen;
    for (std::uint32_t id = 0; id < h.table().size(); ++id) {
      std::vector<std::pair<std::uint32_t, double>> key;
      const SparseMixture m = h.table().mixture(id);
      for (const auto& e : m.entries()) key.push_back({e.index, e.weight});
      EXPECT_TRUE(seen.insert(key).second) << "duplicate mixture " << id;
    }
    EXPECT_EQ(h.level(h.max_level()).dims, (Extent{1, 1, 1}));
  }
}

TEST(MixtureMipmap, ExactRationalCounts) {
  // 3 voxels in a row: level 1 = {(a,b)/2, c}, level 2 = (a/4 + b/4 + c/2): counts 1,1,2 over 4.
  const HistogramMipmap h = HistogramMipmap::from_source_ids({3, 1, 1}, {0, 1, 2}, 3);
  ASSERT_EQ(h.level_count(), 3);
  const std::uint32_t top = h.mixture_id(2, 0, 0, 0);
  const auto ix = h.table().index(top);
  const auto ms = h.table().mass(top);
  ASSERT_EQ(ix.size(), 3u);
  EXPECT_EQ(ms[0], 1.0);
  EXPECT_EQ(ms[1], 1.0);
  EXPECT_EQ(ms[2], 2.0);
  EXPECT_EQ(h.table().total(top), 4.0);
  // The same normalised mixture from a different support size is the same table entry.
  const HistogramMipmap g = HistogramMipmap::from_source_ids({4, 1, 1}, {0, 0, 1, 1}, 2);
  const HistogramMipmap g2 = HistogramMipmap::from_source_ids({2, 1, 1}, {0, 1}, 2);
  EXPECT_EQ(g.table().mass(g.mixture_id(2, 0, 0, 0))[0], 1.0);
  EXPECT_EQ(g2.table().mass(g2.mixture_id(1, 0, 0, 0))[0], 1.0);
  // Uniform regions collapse to the unit mixture (its source id) at every level.
  const HistogramMipmap u = HistogramMipmap::from_source_ids({4, 4, 4}, std::vector<std::uint32_t>(64, 1), 3);
  for (int l = 0; l < u.level_count(); ++l) EXPECT_EQ(u.mixture_id(l, 0, 0, 0), 1u);
}

TEST(MixtureMipmap, FractionalInputMatchesBruteForce) {
  const Extent d{5, 4, 3};
  std::mt19937_64 rng(7);
  FractionalVoxels f;
  f.dims = d;
  f.num_sources = 5;
  std::vector<Dense> l0;
  for (std::int64_t v = 0; v < d.voxel_count(); ++v) {
    Dense m;
    const int k = 1 + int(rng() % 3);
    for (int i = 0; i < k; ++i) m[std::uint32_t(rng() % 5)] += double(1 + rng() % 4);
    double t = 0;
    for (auto& [i, w] : m) t += w;
    for (auto& [i, w] : m) {
      f.index.push_back(i);
      f.weight.push_back(w);  // unnormalised on purpose
      w /= t;
    }
    f.offsets.push_back(f.index.size());
    l0.push_back(m);
  }
  const HistogramMipmap h = HistogramMipmap::from_fractional(f);
  EXPECT_TRUE(h.fractional());
  expect_matches(h, brute_force(d, l0));

  FractionalVoxels bad = f;
  bad.index[0] = 9;
  EXPECT_THROW(HistogramMipmap::from_fractional(bad), Error);
}

TEST(MixtureMipmap, FromLabelsKeepsTheMap) {
  Volume v({4, 2, 2}, DType::i16);
  auto s = v.samples<std::int16_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::int16_t(i % 3 == 0 ? -4 : 900);
  LabelMap map;
  const HistogramMipmap h = HistogramMipmap::from_labels(v, &map);
  EXPECT_EQ(h.num_sources(), 2u);
  EXPECT_EQ(map.value(0), -4);
  EXPECT_TRUE(map.decode(h.level(0).ids, v.dims()) == v);
}

}  // namespace
}  // namespace strata::mixture
