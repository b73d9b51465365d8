// The API in process (no sockets): dataset metadata, frames and their statistics, slices and
// their level choice, voxel values, palettes, box queries, static files, and the errors a
// client sees for bad parameters, unknown datasets and paths.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "server/server_test_util.hpp"
#include "server/static_files.hpp"
#include "support/test_support.hpp"
#include "strata/server/render_queue.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::server {
namespace {

using namespace testing;

std::string dataset(int id, const std::string& endpoint) {
  return "/api/datasets/" + std::to_string(id) + "/" + endpoint;
}

template <class T>
std::vector<T> values_of(const std::string& body) {
  std::vector<T> v(body.size() / sizeof(T));
  std::memcpy(v.data(), body.data(), v.size() * sizeof(T));
  return v;
}

// Pixels that differ from the opaque black background.
std::size_t lit_pixels(const render::Image& image) {
  return std::size_t(std::count_if(image.pixels().begin(), image.pixels().end(),
                                   [](const render::Rgba8& p) { return (p.r | p.g | p.b) != 0; }));
}

class ServerApi : public SharedApiTest {
 protected:
  // Expects 400 with a JSON error naming `parameter`.
  void expect_bad(const std::string& target, const std::string& parameter) {
    const HttpResponse r = get(api(), target);
    EXPECT_EQ(r.status, 400) << target << ": " << r.body;
    if (r.status != 400) return;
    const nlohmann::json j = json_of(r);
    EXPECT_EQ(j.value("parameter", ""), parameter) << target << ": " << r.body;
    EXPECT_FALSE(j.value("error", "").empty()) << target;
    EXPECT_EQ(r.content_type, "application/json");
  }
};

TEST_F(ServerApi, DatasetsDescribeEveryFileInOrder) {
  const HttpResponse r = get(api(), "/api/datasets");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("Cache-Control"), "no-store");
  const nlohmann::json list = json_of(r);
  ASSERT_EQ(list.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(list[std::size_t(i)]["id"], i);

  const nlohmann::json& scalar = list[kScalar];
  EXPECT_EQ(scalar["name"], "prisms.strata");
  EXPECT_EQ(scalar["kind"], "scalar");
  EXPECT_EQ(scalar["dims"], nlohmann::json({48, 40, 36}));
  EXPECT_EQ(scalar["dtype"], "u16");
  EXPECT_EQ(scalar["levels"], 3);
  EXPECT_EQ(scalar["rank"], 8);
  ASSERT_EQ(scalar["histogram"].size(), 64u);
  // One count per level-0 brick (4 x 4 x 3) and bin it touches: at least one each.
  std::uint64_t touched = 0;
  for (const auto& c : scalar["histogram"]) touched += c.get<std::uint64_t>();
  EXPECT_GE(touched, 48u);
  const auto range = scalar["value_range"];
  EXPECT_LT(range[0].get<double>(), range[1].get<double>());

  const nlohmann::json& labels = list[kLabels];
  EXPECT_EQ(labels["kind"], "labels");
  EXPECT_EQ(labels["dims"], nlohmann::json({40, 36, 32}));
  EXPECT_EQ(labels["levels"], 7);  // 40 -> 20 -> 10 -> 5 -> 3 -> 2 -> 1
  EXPECT_EQ(labels["rank"], 0);
  std::set<double> distinct;
  for (std::int64_t z = 0; z < 32; ++z)
    for (std::int64_t y = 0; y < 36; ++y)
      for (std::int64_t x = 0; x < 40; ++x) distinct.insert(data().labels_source().value(x, y, z));
  EXPECT_EQ(labels["label_count"], distinct.size());

  const nlohmann::json& plain = list[kPlain];
  EXPECT_EQ(plain["kind"], "plain");
  EXPECT_EQ(plain["levels"], 1);
  std::uint64_t voxels = 0;
  for (const auto& c : plain["histogram"]) voxels += c.get<std::uint64_t>();
  EXPECT_EQ(voxels, 24u * 20u * 16u) << "plain histograms count every voxel once";
}

// A .strata volume set serves the member --volume names (its members may even use different
// codecs: they share nothing), under "<file> (volume N)"; without a choice it is refused.
TEST(ServerApiVolumeSet, TheChosenMemberIsServed) {
  const ServerData& d = ServerData::get();
  const test::TempDir dir;
  const std::vector<std::filesystem::path> files = d.files();
  const std::filesystem::path set = dir / "set.strata";
  store::write_volume_set(set, {files[kScalar], files[kLabels]}, {});
  for (int member : {0, 1}) {
    ApiOptions options;
    options.volume = member;
    Api api({set}, options);
    const nlohmann::json list = json_of(get(api, "/api/datasets"));
    ASSERT_EQ(list.size(), 1u);
    EXPECT_EQ(list[0]["name"], "set.strata (volume " + std::to_string(member) + ")");
    EXPECT_EQ(list[0]["kind"], member == 0 ? "scalar" : "labels");
    EXPECT_EQ(list[0]["dims"], member == 0 ? nlohmann::json({48, 40, 36}) : nlohmann::json({40, 36, 32}));
    EXPECT_EQ(get(api, dataset(0, "slice?axis=z&index=3")).status, 200);
  }
  const std::string refused = test::error_of([&] { Api api({set}); });
  EXPECT_NE(refused.find("holds 2 volumes; choose one with --volume T (0..1)"), std::string::npos) << refused;
}

TEST_F(ServerApi, ExactFramesArePngWithStatistics) {
  const HttpResponse r = get(api(), dataset(kScalar, "render?w=64&h=48&tf=grayscale"));
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.content_type, "image/png");
  EXPECT_EQ(r.header("Cache-Control"), "no-store");
  const render::Image image = png_of(r.body);
  EXPECT_EQ(image.width(), 64);
  EXPECT_EQ(image.height(), 48);
  EXPECT_GT(lit_pixels(image), 64u * 48u / 10) << "the volume fills the default framing";
  const nlohmann::json s = stats_of(r);
  ASSERT_TRUE(s.is_object());
  EXPECT_EQ(s["quality"], "exact");
  EXPECT_EQ(s["rank"], 8);
  EXPECT_EQ(s["image_scale"], 1.0);
  EXPECT_GT(s["selection"]["bricks"].get<int>(), 0);
  EXPECT_GT(s["load"]["bricks_resident"].get<int>(), 0);
  EXPECT_EQ(s["load"]["bricks_loading"], 0) << "an exact frame waits for its cut";
  EXPECT_TRUE(s["load"].contains("bytes_read"));
  EXPECT_TRUE(s["load"].contains("decode_ms"));
  EXPECT_GE(s["frame_ms"].get<double>(), 0.0);

  for (int id : {kLabels, kPlain}) {
    const HttpResponse other = get(api(), dataset(id, "render?w=40&h=30"));
    ASSERT_EQ(other.status, 200) << other.body;
    const render::Image frame = png_of(other.body);
    EXPECT_EQ(frame.width(), 40);
    EXPECT_GT(lit_pixels(frame), 0u) << "dataset " << id;
  }
}

TEST_F(ServerApi, CoarseFramesAreJpegOnAReducedRayGrid) {
  const HttpResponse r = get(api(), dataset(kScalar, "render?w=96&h=72&quality=coarse&az=60"));
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.content_type, "image/jpeg");
  EXPECT_EQ(jpeg_size(r.body), (std::pair{96, 72}));
  const nlohmann::json s = stats_of(r);
  EXPECT_EQ(s["quality"], "coarse");
  EXPECT_GE(s["image_scale"].get<double>(), 2.0);
  const HttpResponse exact = get(api(), dataset(kScalar, "render?w=96&h=72&az=60"));
  EXPECT_LE(s["selection"]["bricks"].get<int>(), stats_of(exact)["selection"]["bricks"].get<int>())
      << "larger pixels never refine further";
  const HttpResponse png = get(api(), dataset(kScalar, "render?w=96&h=72&quality=coarse&format=png"));
  EXPECT_EQ(png.content_type, "image/png");
  EXPECT_EQ(png_of(png.body).width(), 96);
}

TEST(ServerApiRank, RankChangeReusesCachedModels) {
  const auto api = make_api();
  const HttpResponse first = get(*api, dataset(kScalar, "render?w=64&h=48&el=30"));
  ASSERT_EQ(first.status, 200) << first.body;
  const nlohmann::json s1 = stats_of(first);
  EXPECT_GT(s1["load"]["bytes_read"].get<std::uint64_t>(), 0u) << "a cold cache reads the file";
  const HttpResponse second = get(*api, dataset(kScalar, "render?w=64&h=48&el=30&rank=3"));
  ASSERT_EQ(second.status, 200) << second.body;
  const nlohmann::json s2 = stats_of(second);
  EXPECT_EQ(s2["rank"], 3);
  EXPECT_GT(s2["load"]["cache_misses"].get<int>(), 0) << "rank 3 bricks are reconstructed anew";
  EXPECT_EQ(s2["load"]["bytes_read"], 0) << "from the cached models, without reading";
  EXPECT_NE(png_of(first.body).pixels(), png_of(second.body).pixels()) << "rank 3 looks different";
}

TEST_F(ServerApi, BadRenderParametersAreNamed) {
  const std::string render = dataset(kScalar, "render?");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"w=0", "w"},          {"w=4097", "w"},       {"h=abc", "h"},          {"w=1e3", "w"},
      {"h=12.5", "h"},       {"az=nan", "az"},      {"az=inf", "az"},        {"el=91", "el"},
      {"el=-90.5", "el"},    {"dist=0", "dist"},    {"dist=-2", "dist"},     {"fov=180", "fov"},
      {"fov=0", "fov"},      {"target=1,2", "target"}, {"target=1,2,x", "target"}, {"tf=/etc/passwd", "tf"},
      {"tf=nope", "tf"},     {"tf=0:1:1:1:1", "tf"}, {"tf=5:0:0:0:0;1:1:1:1:1", "tf"}, {"tf=0:2:0:0:1;9:1:1:1:1", "tf"},
      {"rank=0", "rank"},    {"rank=9", "rank"},    {"lod=0", "lod"},        {"lod=65", "lod"},
      {"step=0.01", "step"}, {"step=5", "step"},    {"shading=2", "shading"}, {"quality=fast", "quality"},
      {"format=gif", "format"}, {"client=a", "seq"}, {"seq=1", "client"},     {"client=a%20b&seq=1", "client"},
      {"client=a&seq=-1", "seq"}, {"foo=1", "foo"}, {"w=10&w=20", "w"},     {"w=", "w"},
      {"pass=-1", "pass"},    {"pass=256", "pass"}, {"pass=1e99", "pass"},  {"pass=nan", "pass"},
  };
  for (const auto& [query, parameter] : cases) expect_bad(render + query, parameter);
  expect_bad(dataset(kLabels, "render?tf=ct"), "tf");
  expect_bad(dataset(kPlain, "render?rank=1"), "rank");
  expect_bad(dataset(kLabels, "render?rank=1"), "rank");
  // Lighting is for label files, and normals lighting for those with a normals graph.
  expect_bad(dataset(kScalar, "render?lighting=gradient"), "lighting");
  expect_bad(dataset(kLabels, "render?lighting=normals"), "lighting");
  expect_bad(dataset(kLabels, "render?lighting=phong"), "lighting");
  EXPECT_EQ(get(api(), dataset(kLabels, "render?w=32&h=24&lighting=gradient")).status, 200);
}

TEST_F(ServerApi, TransferFunctionText) {
  const HttpResponse r = get(api(), dataset(kScalar, "render?w=32&h=24&tf=0:0:0:0:0;20000:1:0.5:0:0.5;65535:1:1:1:1"));
  EXPECT_EQ(r.status, 200) << r.body;
  const HttpResponse clear = get(api(), dataset(kScalar, "render?w=32&h=24&tf=0:1:1:1:0;65535:1:1:1:0"));
  ASSERT_EQ(clear.status, 200) << clear.body;
  EXPECT_EQ(lit_pixels(png_of(clear.body)), 0u) << "a fully transparent TF shows the background";
}

TEST_F(ServerApi, UnknownDatasetsAndPathsAre404) {
  for (const std::string target :
       {"/api/datasets/3/render", "/api/datasets/-1/value?x=0&y=0&z=0", "/api/datasets/01/render",
        "/api/datasets/abc/slice", "/api/datasets/0", "/api/datasets/0/", "/api/datasets/0/nothing", "/api/nothing",
        "/api/datasets/", "/index.html", "/static/", "/static/nothing.js", "/etc/passwd", "/static/../CMakeLists.txt",
        "/static/%2e%2e/CMakeLists.txt", "/static/%2E%2E/%2E%2E/etc/passwd", "/static//etc/passwd",
        "/static/./index.html", "/%2e%2e/etc/passwd"}) {
    const HttpResponse r = get(api(), target);
    EXPECT_EQ(r.status, 404) << target << ": " << r.body;
    EXPECT_EQ(r.header("Cache-Control"), "no-store");
  }
  EXPECT_EQ(json_of(get(api(), "/api/datasets/7/render")).value("parameter", ""), "id");
  const HttpResponse wrong_method = post(api(), dataset(kScalar, "render"), "");
  EXPECT_EQ(wrong_method.status, 405);
  EXPECT_EQ(wrong_method.header("Allow"), "GET");
  EXPECT_EQ(get(api(), dataset(kLabels, "palette")).status, 405);
  EXPECT_EQ(post(api(), "/api/datasets", "").header("Allow"), "GET");
  EXPECT_EQ(api().handle(make_request("DELETE", "/")).status, 405);
  expect_bad("/api/datasets?x=1", "x");
}

TEST_F(ServerApi, PlainSlicesInEveryOrientation) {
  const Volume& v = data().plain_source();
  struct Case {
    std::string axis;
    std::int64_t index;
    int w, h;
  };
  for (const Case& c : {Case{"z", 5, 24, 20}, Case{"y", 3, 24, 16}, Case{"x", 7, 20, 16}}) {
    const HttpResponse r = get(api(), dataset(kPlain, "slice?format=raw&axis=" + c.axis + "&index=" + std::to_string(c.index)));
    ASSERT_EQ(r.status, 200) << r.body;
    EXPECT_EQ(r.content_type, "application/octet-stream");
    EXPECT_EQ(r.header("X-Strata-Dims"), std::to_string(c.w) + "," + std::to_string(c.h));
    EXPECT_EQ(r.header("X-Strata-Level"), "0");
    const std::vector<float> values = values_of<float>(r.body);
    ASSERT_EQ(values.size(), std::size_t(c.w * c.h));
    for (int row = 0; row < c.h; ++row)
      for (int col = 0; col < c.w; ++col) {
        const double expected = c.axis == "z"   ? v.value(col, row, c.index)
                                : c.axis == "y" ? v.value(col, c.index, row)
                                                : v.value(c.index, col, row);
        ASSERT_EQ(values[std::size_t(row * c.w + col)], float(expected)) << c.axis << " u " << col << " v " << row;
      }
  }
}

TEST_F(ServerApi, ScalarSlicesMatchTheCodecAtEveryLevel) {
  for (int level : {0, 1, 2}) {
    const Volume expected = data().scalar_level(level, 8);
    const std::int64_t index = 13;  // level-0 slice: level l shows 13 >> l
    const HttpResponse r =
        get(api(), dataset(kScalar, "slice?format=raw&axis=y&index=13&level=" + std::to_string(level)));
    ASSERT_EQ(r.status, 200) << r.body;
    EXPECT_EQ(r.header("X-Strata-Level"), std::to_string(level));
    const Extent d = expected.dims();
    EXPECT_EQ(r.header("X-Strata-Dims"), std::to_string(d.x) + "," + std::to_string(d.z));
    const std::vector<float> values = values_of<float>(r.body);
    ASSERT_EQ(values.size(), std::size_t(d.x * d.z));
    double worst = 0;
    for (std::int64_t z = 0; z < d.z; ++z)
      for (std::int64_t x = 0; x < d.x; ++x)
        worst = std::max(worst, std::abs(values[std::size_t(z * d.x + x)] - expected.value(x, index >> level, z)));
    EXPECT_LT(worst, 0.05) << "level " << level << ": the same reconstruction as TaVolume::decode_box";
  }
}

TEST_F(ServerApi, SliceLevelFollowsZoom) {
  const std::vector<std::pair<std::string, std::string>> zooms = {
      {"zoom=1", "0"}, {"zoom=4", "0"}, {"zoom=0.5", "1"}, {"zoom=0.3", "2"}, {"zoom=0.25", "2"}, {"zoom=0.01", "2"}, {"", "0"}};
  for (const auto& [zoom, level] : zooms) {
    const HttpResponse r = get(api(), dataset(kScalar, "slice?axis=z&index=20&" + zoom));
    ASSERT_EQ(r.status, 200) << zoom << ": " << r.body;
    EXPECT_EQ(r.header("X-Strata-Level"), level) << zoom;
  }
  EXPECT_EQ(get(api(), dataset(kScalar, "slice?axis=z&index=20&zoom=0.5")).header("X-Strata-Dims"), "24,20");
  EXPECT_EQ(get(api(), dataset(kLabels, "slice?axis=z&index=3&zoom=0.125")).header("X-Strata-Level"), "3");
  const HttpResponse png = get(api(), dataset(kScalar, "slice?axis=x&index=2&zoom=0.5"));
  EXPECT_EQ(png.content_type, "image/png");
  const render::Image image = png_of(png.body);
  EXPECT_EQ(image.width(), 20);   // level 1: y 40 -> 20
  EXPECT_EQ(image.height(), 18);  // z 36 -> 18
}

TEST_F(ServerApi, SliceWindowMapsValuesToGrey) {
  const std::string common = "slice?axis=z&index=9&rank=4";
  const std::vector<float> values = values_of<float>(get(api(), dataset(kScalar, common + "&format=raw")).body);
  const HttpResponse r = get(api(), dataset(kScalar, common + "&window=1000,30000"));
  ASSERT_EQ(r.status, 200) << r.body;
  const render::Image image = png_of(r.body);
  ASSERT_EQ(image.pixels().size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double g = std::clamp((values[i] - 1000.0) / 29000.0, 0.0, 1.0) * 255.0;
    ASSERT_NEAR(image.pixels()[i].r, g, 0.51) << i;
  }
  const HttpResponse tf = get(api(), dataset(kScalar, common + "&tf=fire"));
  EXPECT_EQ(tf.status, 200) << tf.body;
}

TEST_F(ServerApi, LabelSlices) {
  const Volume& labels = data().labels_source();
  const HttpResponse level0 = get(api(), dataset(kLabels, "slice?axis=z&index=11&format=raw"));
  ASSERT_EQ(level0.status, 200) << level0.body;
  const std::vector<std::uint32_t> ids = values_of<std::uint32_t>(level0.body);
  ASSERT_EQ(ids.size(), 40u * 36u);
  for (std::int64_t y = 0; y < 36; ++y)
    for (std::int64_t x = 0; x < 40; ++x)
      ASSERT_EQ(ids[std::size_t(y * 40 + x)], std::uint32_t(labels.value(x, y, 11))) << x << "," << y;

  const Volume dominant = data().dominant_labels(2);
  const HttpResponse level2 = get(api(), dataset(kLabels, "slice?axis=x&index=17&level=2&format=raw"));
  ASSERT_EQ(level2.header("X-Strata-Dims"), "9,8");
  const std::vector<std::uint32_t> coarse = values_of<std::uint32_t>(level2.body);
  for (std::int64_t z = 0; z < 8; ++z)
    for (std::int64_t y = 0; y < 9; ++y)
      ASSERT_EQ(coarse[std::size_t(z * 9 + y)], std::uint32_t(dominant.value(17 >> 2, y, z)));

  const std::int64_t label = std::int64_t(labels.value(20, 18, 11));
  ASSERT_NE(label, 0);
  const HttpResponse fraction =
      get(api(), dataset(kLabels, "slice?axis=z&index=11&format=raw&label=" + std::to_string(label)));
  ASSERT_EQ(fraction.status, 200) << fraction.body;
  const std::vector<float> f = values_of<float>(fraction.body);
  for (std::int64_t y = 0; y < 36; ++y)
    for (std::int64_t x = 0; x < 40; ++x)
      ASSERT_NEAR(f[std::size_t(y * 40 + x)], labels.value(x, y, 11) == double(label) ? 1.0 : 0.0, 1e-6);
  const HttpResponse grey = get(api(), dataset(kLabels, "slice?axis=z&index=11&level=1&label=" + std::to_string(label)));
  EXPECT_EQ(grey.content_type, "image/png");
  EXPECT_EQ(png_of(grey.body).width(), 20);
}

TEST_F(ServerApi, BadSliceParametersAreNamed) {
  expect_bad(dataset(kScalar, "slice?index=3"), "axis");
  expect_bad(dataset(kScalar, "slice?axis=w&index=3"), "axis");
  expect_bad(dataset(kScalar, "slice?axis=z"), "index");
  expect_bad(dataset(kScalar, "slice?axis=z&index=36"), "index");
  expect_bad(dataset(kScalar, "slice?axis=x&index=-1"), "index");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&level=3"), "level");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&zoom=0"), "zoom");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&zoom=-1"), "zoom");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&level=1&zoom=1"), "zoom");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&window=5,5"), "window");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&window=5"), "window");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&window=0,1&tf=ct"), "tf");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&label=1"), "label");
  expect_bad(dataset(kScalar, "slice?axis=z&index=3&format=jpeg"), "format");
  expect_bad(dataset(kPlain, "slice?axis=z&index=3&level=1"), "level");
  expect_bad(dataset(kLabels, "slice?axis=z&index=3&window=0,1"), "window");
  expect_bad(dataset(kLabels, "slice?axis=z&index=3&label=999999"), "label");
  expect_bad(dataset(kLabels, "slice?axis=z&index=3&rank=1"), "rank");
}

TEST_F(ServerApi, VoxelValues) {
  const HttpResponse plain = get(api(), dataset(kPlain, "value?x=12&y=9&z=7"));
  ASSERT_EQ(plain.status, 200) << plain.body;
  EXPECT_EQ(json_of(plain)["value"].get<double>(), double(float(data().plain_source().value(12, 9, 7))));
  const HttpResponse label = get(api(), dataset(kLabels, "value?x=20&y=18&z=11"));
  EXPECT_EQ(json_of(label)["label"].get<std::int64_t>(), std::int64_t(data().labels_source().value(20, 18, 11)));
  const Volume decoded = data().scalar_level(0, 5);
  const HttpResponse scalar = get(api(), dataset(kScalar, "value?x=30&y=21&z=33&rank=5"));
  EXPECT_NEAR(json_of(scalar)["value"].get<double>(), decoded.value(30, 21, 33), 0.05);
  expect_bad(dataset(kScalar, "value?x=48&y=0&z=0"), "x");
  expect_bad(dataset(kScalar, "value?x=0&y=0"), "z");
  expect_bad(dataset(kScalar, "value?x=0&y=0&z=0&rank=12"), "rank");
  expect_bad(dataset(kLabels, "value?x=0&y=0&z=0&rank=1"), "rank");
}

TEST(ServerApiPalette, RecoloursSlicesThroughTheGraph) {
  const auto api = make_api();
  const Volume& v = ServerData::get().labels_source();
  const std::int64_t red = std::int64_t(v.value(20, 18, 11)), hidden = std::int64_t(v.value(3, 30, 11));
  ASSERT_NE(red, hidden);
  const std::string body = R"({"colors": {")" + std::to_string(red) + R"(": "#ff0000"}, "hidden": [)" +
                           std::to_string(hidden) + R"(], "default": "#00ff00", "opacity": 0.5})";
  const auto t0 = std::chrono::steady_clock::now();
  const HttpResponse r = post(*api, dataset(kLabels, "palette"), body);
  const double request_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(r.status, 200) << r.body;
  const nlohmann::json j = json_of(r);
  // The propagation through the graph is done by the request and timed in milliseconds: some
  // time, and no more than the whole request took.
  EXPECT_GT(j["palette_ms"].get<double>(), 0.0) << "the palette is propagated, and timed, by the request";
  EXPECT_LE(j["palette_ms"].get<double>(), request_ms) << "palette_ms is part of the request's time, in ms";
  // The next frame finds the palette propagated, not left for it to do.
  const HttpResponse after = get(*api, dataset(kLabels, "render?w=32&h=24"));
  ASSERT_EQ(after.status, 200) << after.body;
  EXPECT_EQ(stats_of(after)["palette_ms"], 0.0) << after.header("X-Strata-Stats").value_or("");
  EXPECT_EQ(j["labels"], json_of(get(*api, "/api/datasets"))[kLabels]["label_count"]);

  const render::Image slice = png_of(get(*api, dataset(kLabels, "slice?axis=z&index=11")).body);
  for (std::int64_t y = 0; y < 36; ++y)
    for (std::int64_t x = 0; x < 40; ++x) {
      const std::int64_t l = std::int64_t(v.value(x, y, 11));
      const render::Rgba8 expected = l == red ? render::Rgba8{255, 0, 0, 255}
                                     : l == hidden || l == 0 ? render::Rgba8{0, 0, 0, 0}
                                                             : render::Rgba8{0, 255, 0, 255};
      ASSERT_EQ(slice.at(int(x), int(y)), expected) << x << "," << y << " label " << l;
    }

  // In 3D the cells hide each other: hide all but the red one, which must then show alone.
  std::set<std::int64_t> others;
  for (std::int64_t z = 0; z < 32; ++z)
    for (std::int64_t y = 0; y < 36; ++y)
      for (std::int64_t x = 0; x < 40; ++x)
        if (const auto l = std::int64_t(v.value(x, y, z)); l != red && l != 0) others.insert(l);
  nlohmann::json only_red{{"colors", {{std::to_string(red), "#ff0000"}}}, {"hidden", others}};
  ASSERT_EQ(post(*api, dataset(kLabels, "palette"), only_red.dump()).status, 200);
  const HttpResponse frame = get(*api, dataset(kLabels, "render?w=48&h=36"));
  ASSERT_EQ(frame.status, 200);
  const render::Image image = png_of(frame.body);
  std::size_t red_pixels = 0;
  for (const render::Rgba8& p : image.pixels()) {
    EXPECT_EQ(p.b, 0) << "only the red label is visible";
    red_pixels += p.r > 40 && p.g < p.r / 2;
  }
  EXPECT_GT(red_pixels, 10u) << "the red label shows in 3D";
}

TEST(ServerApiPick, PicksTheLabelAPixelShowsAndPassesHiddenOnes) {
  // The centre pixel of a view along -x (azimuth 90, elevation 0): the first voxel whose label
  // is visible; hiding that label moves the pick deeper, to a voxel of another label.
  const auto api = make_api();
  const std::string view = "pick?w=64&h=48&az=90&el=0&x=31.5&y=23.5";
  const nlohmann::json first = json_of(get(*api, dataset(kLabels, view)));
  ASSERT_TRUE(first["hit"].get<bool>()) << first.dump();
  const std::int64_t label = first["label"];
  const auto& voxel = first["voxel"];
  const std::string at = fmt::format("value?x={}&y={}&z={}", voxel[0].get<std::int64_t>(), voxel[1].get<std::int64_t>(),
                                     voxel[2].get<std::int64_t>());
  EXPECT_EQ(json_of(get(*api, dataset(kLabels, at)))["label"], label);
  EXPECT_EQ(voxel[0], 39) << "a label fills the volume's +x face";
  const nlohmann::json palette{{"hidden", {label}}};
  ASSERT_EQ(post(*api, dataset(kLabels, "palette"), palette.dump()).status, 200);
  const nlohmann::json second = json_of(get(*api, dataset(kLabels, view)));
  ASSERT_TRUE(second["hit"].get<bool>()) << second.dump();
  EXPECT_NE(second["label"], label);
  EXPECT_GT(second["distance"].get<double>(), first["distance"].get<double>());
  // A corner pixel looks past the volume.
  EXPECT_FALSE(json_of(get(*api, dataset(kLabels, "pick?w=64&h=48&az=90&el=0&x=0&y=0")))["hit"].get<bool>());
}

TEST(ServerApiPick, PicksWhereAScalarViewTurnsOpaque) {
  const auto api = make_api();
  const nlohmann::json hit = json_of(get(*api, dataset(kPlain, "pick?w=64&h=48&x=31.5&y=23.5&tf=0:1:1:1:0;0.5:1:1:1:0;0.6:1:1:1:0.9;1:1:1:1:0.9")));
  ASSERT_TRUE(hit["hit"].get<bool>()) << hit.dump();
  const auto& voxel = hit["voxel"];
  const std::string at = fmt::format("value?x={}&y={}&z={}", voxel[0].get<std::int64_t>(), voxel[1].get<std::int64_t>(),
                                     voxel[2].get<std::int64_t>());
  EXPECT_DOUBLE_EQ(json_of(get(*api, dataset(kPlain, at)))["value"].get<double>(), hit["value"].get<double>());
  const nlohmann::json clear = json_of(get(*api, dataset(kPlain, "pick?w=64&h=48&x=31.5&y=23.5&tf=0:1:1:1:0;1:1:1:1:0")));
  EXPECT_FALSE(clear["hit"].get<bool>());
}

TEST(ServerApiPick, BadPickParametersAreNamed) {
  const auto api = make_api();
  auto expect_bad = [&](const std::string& url, const std::string& parameter) {
    const HttpResponse r = get(*api, url);
    EXPECT_EQ(r.status, 400) << url;
    EXPECT_EQ(json_of(r)["parameter"], parameter) << url << ": " << r.body;
  };
  expect_bad(dataset(kScalar, "pick?y=1"), "x");
  expect_bad(dataset(kScalar, "pick?x=1"), "y");
  expect_bad(dataset(kScalar, "pick?w=64&h=48&x=63.5&y=1"), "x");
  expect_bad(dataset(kScalar, "pick?w=64&h=48&x=1&y=-0.6"), "y");
  expect_bad(dataset(kScalar, "pick?x=nan&y=1"), "x");
  expect_bad(dataset(kScalar, "pick?x=1&y=1&step=1"), "step");
  expect_bad(dataset(kScalar, "pick?x=1&y=1&rank=9"), "rank");
  expect_bad(dataset(kLabels, "pick?x=1&y=1&tf=ct"), "tf");
  expect_bad(dataset(kPlain, "pick?x=1&y=1&rank=1"), "rank");
  EXPECT_EQ(post(*api, dataset(kScalar, "pick?x=1&y=1"), "").status, 405);
}

TEST(ServerApiPalette, OnlyShowsTheListedLabelsInTheirColours) {
  // "only" turns every other label transparent, whatever their number: one short list instead
  // of a "hidden" list of all the rest. Listed labels keep their colour (own, else the default);
  // "hidden" still wins over it.
  const auto api = make_api();
  const Volume& v = ServerData::get().labels_source();
  const std::int64_t red = std::int64_t(v.value(20, 18, 11)), green = std::int64_t(v.value(3, 30, 11)),
                     gone = std::int64_t(v.value(30, 5, 11));
  ASSERT_TRUE(red != green && green != gone && red != gone && gone != 0);
  nlohmann::json body{{"colors", {{std::to_string(red), "#ff0000"}}},
                      {"default", "#00ff00"},
                      {"only", {red, green, gone}},
                      {"hidden", {gone}}};
  ASSERT_EQ(post(*api, dataset(kLabels, "palette"), body.dump()).status, 200);
  const render::Image slice = png_of(get(*api, dataset(kLabels, "slice?axis=z&index=11")).body);
  int shown = 0;
  for (std::int64_t y = 0; y < 36; ++y)
    for (std::int64_t x = 0; x < 40; ++x) {
      const std::int64_t l = std::int64_t(v.value(x, y, 11));
      const render::Rgba8 expected = l == red     ? render::Rgba8{255, 0, 0, 255}
                                     : l == green ? render::Rgba8{0, 255, 0, 255}
                                                  : render::Rgba8{0, 0, 0, 0};
      ASSERT_EQ(slice.at(int(x), int(y)), expected) << x << "," << y << " label " << l;
      shown += expected.a > 0;
    }
  EXPECT_GT(shown, 0);
  const HttpResponse bad = post(*api, dataset(kLabels, "palette"), R"({"only": [999999]})");
  EXPECT_EQ(bad.status, 400);
  EXPECT_EQ(json_of(bad)["parameter"], "only");
}

TEST_F(ServerApi, BadPalettesAreNamed) {
  const std::string palette = dataset(kLabels, "palette");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"not json", "body"},
      {"[1, 2]", "body"},
      {R"({"colors": {"1": "red"}})", "colors.1"},
      {R"({"colors": {"x": "#ff0000"}})", "colors.x"},
      {R"({"colors": {"999999": "#ff0000"}})", "colors.999999"},
      {R"({"colors": []})", "colors"},
      {R"({"hidden": 3})", "hidden"},
      {R"({"hidden": [999999]})", "hidden"},
      {R"({"default": "#12345"})", "default"},
      {R"({"opacity": 2})", "opacity"},
      {R"({"opacity": "1"})", "opacity"},
      {R"({"colours": {}})", "colours"},
  };
  for (const auto& [body, parameter] : cases) {
    const HttpResponse r = post(api(), palette, body);
    EXPECT_EQ(r.status, 400) << body;
    EXPECT_EQ(json_of(r).value("parameter", ""), parameter) << body << ": " << r.body;
  }
  const HttpResponse scalar = post(api(), dataset(kScalar, "palette"), "{}");
  EXPECT_EQ(scalar.status, 400);
  EXPECT_EQ(json_of(scalar).value("parameter", ""), "id");
}

TEST_F(ServerApi, NaiveQueriesCountTheBoxExactly) {
  const Volume& v = data().labels_source();
  const Box box{{3, 5, 2}, {29, 31, 27}};
  std::map<std::int64_t, double> exact;
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
      for (std::int64_t x = box.lo.x; x < box.hi.x; ++x) exact[std::int64_t(v.value(x, y, z))] += 1;
  const HttpResponse r = get(api(), dataset(kLabels, "query?box=3,5,2,29,31,27&method=naive"));
  ASSERT_EQ(r.status, 200) << r.body;
  const nlohmann::json j = json_of(r);
  EXPECT_EQ(j["method"], "naive");
  EXPECT_EQ(j["voxels"], box.voxel_count());
  EXPECT_EQ(j["box"], nlohmann::json({3, 5, 2, 29, 31, 27}));
  double total = 0, previous = 1e300;
  ASSERT_EQ(j["labels"].size(), exact.size());
  for (const auto& entry : j["labels"]) {
    const double count = entry["count"].get<double>();
    total += count;
    EXPECT_LE(count, previous) << "descending counts";
    previous = count;
    EXPECT_EQ(count, exact[entry["label"].get<std::int64_t>()]) << "label " << entry["label"];
    EXPECT_EQ(entry["sigma"], 0.0);
  }
  EXPECT_EQ(total, double(box.voxel_count()));
  for (const std::string method : {"hybrid", "footprint", "coarse"}) {
    const nlohmann::json m = json_of(get(api(), dataset(kLabels, "query?box=3,5,2,29,31,27&method=" + method)));
    double sum = 0;
    for (const auto& entry : m["labels"]) sum += entry["count"].get<double>();
    EXPECT_NEAR(sum, double(box.voxel_count()), 1e-6 * double(box.voxel_count())) << method;
  }
  EXPECT_EQ(json_of(get(api(), dataset(kLabels, "query?box=0,0,0,40,36,32")))["method"], "hybrid");
}

TEST_F(ServerApi, BadQueriesAreNamed) {
  expect_bad(dataset(kLabels, "query"), "box");
  expect_bad(dataset(kLabels, "query?box=0,0,0,41,36,32"), "box");
  expect_bad(dataset(kLabels, "query?box=-1,0,0,4,4,4"), "box");
  expect_bad(dataset(kLabels, "query?box=4,0,0,4,4,4"), "box");
  expect_bad(dataset(kLabels, "query?box=0,0,0,4,4"), "box");
  expect_bad(dataset(kLabels, "query?box=0,0,0,4,4,4,4"), "box");
  expect_bad(dataset(kLabels, "query?box=0,0,0,4,4,4&method=exact"), "method");
  expect_bad(dataset(kScalar, "query?box=0,0,0,4,4,4"), "id");
}

TEST_F(ServerApi, SupersededQueuedFramesAre204) {
  RenderQueue& queue = api().render_queue();
  queue.pause();
  HttpResponse older, newer;
  std::thread first([&] { older = get(api(), dataset(kScalar, "render?w=32&h=24&client=viewer-1&seq=1")); });
  ASSERT_TRUE(eventually([&] { return queue.queued() == 1; })) << "the first frame waits in the paused queue";
  std::thread second([&] { newer = get(api(), dataset(kScalar, "render?w=32&h=24&client=viewer-1&seq=2")); });
  first.join();  // answered while the queue is still paused: dropped, never rendered
  EXPECT_EQ(older.status, 204);
  EXPECT_TRUE(older.body.empty());
  EXPECT_EQ(queue.queued(), 1u);
  queue.resume();
  second.join();
  EXPECT_EQ(newer.status, 200) << newer.body;
  EXPECT_EQ(newer.content_type, "image/png");
  const HttpResponse stale = get(api(), dataset(kScalar, "render?w=32&h=24&client=viewer-1&seq=1"));
  EXPECT_EQ(stale.status, 204) << "an older frame arriving late is dropped";
}

TEST(ServerApiQueue, OverfullQueueIs503) {
  ApiOptions options;
  options.queue_capacity = 2;
  const auto api = make_api(options);
  RenderQueue& queue = api->render_queue();
  queue.pause();
  std::vector<HttpResponse> waiting(2);
  std::vector<std::thread> threads;
  for (int i = 0; i < 2; ++i)
    threads.emplace_back([&, i] { waiting[std::size_t(i)] = get(*api, dataset(kPlain, "render?w=16&h=16")); });
  ASSERT_TRUE(eventually([&] { return queue.queued() == 2; }));
  const HttpResponse refused = get(*api, dataset(kPlain, "render?w=16&h=16"));
  EXPECT_EQ(refused.status, 503);
  EXPECT_EQ(refused.header("Retry-After"), "1");
  EXPECT_FALSE(json_of(refused).value("error", "").empty());
  queue.resume();
  for (auto& t : threads) t.join();
  for (const HttpResponse& r : waiting) EXPECT_EQ(r.status, 200);
}

// Every file of web/ (but hidden ones) is compiled in and served byte for byte at
// /static/<path>, index.html also at /; without web/ files, / says the client is missing.
TEST_F(ServerApi, ClientFilesAreCompiledIn) {
  namespace fs = std::filesystem;
  const fs::path web = fs::path(STRATA_TEST_DATA_DIR).parent_path().parent_path() / "web";
  std::set<std::string> on_disk;
  if (fs::is_directory(web))
    for (auto it = fs::recursive_directory_iterator(web); it != fs::recursive_directory_iterator(); ++it) {
      const std::string rel = fs::relative(it->path(), web).generic_string();
      if (rel.starts_with(".") || rel.find("/.") != std::string::npos) {
        if (it->is_directory()) it.disable_recursion_pending();
        continue;
      }
      if (it->is_regular_file()) on_disk.insert(rel);
    }
  std::set<std::string> compiled;
  for (const auto& f : detail::embedded_files()) compiled.insert(f.path);
  EXPECT_EQ(compiled, on_disk) << "the build embeds exactly the files of web/ (reconfigure picks up new ones)";
  for (const auto& f : detail::embedded_files()) {
    const HttpResponse r = get(api(), std::string("/static/") + f.path);
    ASSERT_EQ(r.status, 200) << f.path;
    EXPECT_EQ(r.body, std::string(reinterpret_cast<const char*>(f.data), f.size)) << f.path;
    if (std::string_view(f.path).ends_with(".js")) {
      EXPECT_EQ(r.content_type, "text/javascript; charset=utf-8") << f.path;
    }
  }
  const HttpResponse root = get(api(), "/");
  ASSERT_EQ(root.status, 200);
  EXPECT_EQ(root.content_type, "text/html; charset=utf-8");
  if (const auto index = detail::find_embedded("index.html")) {
    EXPECT_EQ(root.body, std::string(reinterpret_cast<const char*>(index->data), index->size));
  } else {
    EXPECT_NE(root.body.find("client is missing"), std::string::npos);
  }
}

TEST(ServerApiOptions, CacheBudgetMustGiveEachFileAUsefulShare) {
  ApiOptions options;
  options.cache_bytes = 7ull << 20;  // 3.5 MiB for each of the two .strata files
  EXPECT_EQ(test::parameter_of([&] { make_api(options); }), "ApiOptions::cache_bytes");
  options.cache_bytes = 8ull << 20;
  EXPECT_EQ(make_api(options)->dataset_count(), 3u);
}

}  // namespace
}  // namespace strata::server
