// The render endpoint's error target (fs, paper 2's Alg. 2) on a ta-global file: it is listed
// with its feature-scale ladder, frames report bricks per rank, a larger target never draws
// more bricks, and files without a table refuse the parameter by name.
#include <gtest/gtest.h>

#include <filesystem>

#include "server/server_test_util.hpp"
#include "strata/core/progress.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/quant/scheme.hpp"
#include "strata/ta/compress.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::server;
using namespace strata::server::testing;

namespace {

// ServerData's prisms coded by ta-global at rank 8, in `dir`.
std::filesystem::path global_prisms(const std::filesystem::path& dir) {
  io::write_volume(dir / "prisms.nrrd", ServerData::get().scalar_source());
  ta::CompressParams params;
  params.codec_name = ta::kGlobalCodecName;
  params.layout = {16, 2};
  params.codec.rank = 8;
  params.codec.quant = quant::QuantScheme::parse("u16,b8log+");
  auto source = io::open_volume(dir / "prisms.nrrd");
  ta::compress_volume(*source, dir / "global.strata", params, silent_progress());
  return dir / "global.strata";
}

std::int64_t sum_of(const nlohmann::json& counts) {
  std::int64_t n = 0;
  for (const auto& [key, value] : counts.items()) n += value.get<std::int64_t>();
  return n;
}

}  // namespace

TEST(ServerApiFeatureScale, ErrorTargetsChooseRanksOnGlobalFiles) {
  const test::TempDir dir;
  Api api(std::vector<std::filesystem::path>{global_prisms(dir.path())});
  const nlohmann::json list = json_of(get(api, "/api/datasets"));
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0]["feature_scale_ladder"], nlohmann::json({2, 4, 6, 8}));

  const HttpResponse off = get(api, "/api/datasets/0/render?w=64&h=48");
  ASSERT_EQ(off.status, 200) << off.body;
  EXPECT_FALSE(stats_of(off)["selection"].contains("per_rank")) << "no target, no per-rank figures";

  std::int64_t previous = -1;
  for (const char* fs : {"0.002", "0.05", "1"}) {
    const HttpResponse r = get(api, std::string("/api/datasets/0/render?w=64&h=48&fs=") + fs);
    ASSERT_EQ(r.status, 200) << fs << ": " << r.body;
    const nlohmann::json s = stats_of(r)["selection"];
    ASSERT_TRUE(s.contains("per_rank")) << fs;
    const std::int64_t bricks = s["bricks"].get<std::int64_t>();
    EXPECT_EQ(sum_of(s["per_rank"]), bricks) << fs;
    if (previous >= 0) {
      EXPECT_LE(bricks, previous) << "a larger target draws no more bricks (fs " << fs << ")";
    }
    previous = bricks;
  }
  EXPECT_EQ(previous, 1) << "a target of the whole value range keeps the root alone";
}

TEST(ServerApiFeatureScale, FilesWithoutATableRefuseTheParameter) {
  const auto api = make_api();
  for (const std::string query : {"render?fs=0.01", "render?fs=2", "render?fs=-1", "render?fs=x"}) {
    const HttpResponse r = get(*api, "/api/datasets/" + std::to_string(kScalar) + "/" + query);
    EXPECT_EQ(r.status, 400) << query << ": " << r.body;
    EXPECT_EQ(json_of(r).value("parameter", ""), "fs") << query;
  }
  EXPECT_EQ(get(*api, "/api/datasets/" + std::to_string(kScalar) + "/render?w=32&h=24&fs=0").status, 200);
}
