// The chunked views of `strata serve`: every level of a .strata file as a Neuroglancer
// precomputed volume and as an OME-Zarr image. The served files are copied into folders and read
// back by Strata's own precomputed and Zarr readers, which must return each level exactly as the
// file decodes it; then the names, CORS and the 404s of requests outside the views.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "server/server_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;
using namespace testing;

void save(const fs::path& file, const std::string& bytes) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  ASSERT_TRUE(out.flush()) << file;
}

HttpResponse ok(Api& api, const std::string& target) {
  HttpResponse r = get(api, target);
  EXPECT_EQ(r.status, 200) << target << ": " << r.body;
  return r;
}

// Every file of /precomputed/<name>/ saved under `folder`, chunk names made from the info.
void copy_precomputed(Api& api, const std::string& name, const fs::path& folder) {
  const std::string root = "/precomputed/" + name + "/";
  const HttpResponse info = ok(api, root + "info");
  save(folder / "info", info.body);
  const nlohmann::json description = json_of(info);
  for (const nlohmann::json& scale : description["scales"]) {
    const auto size = scale["size"].get<std::vector<std::int64_t>>();
    const auto offset = scale["voxel_offset"].get<std::vector<std::int64_t>>();
    const auto chunk = scale["chunk_sizes"][0].get<std::vector<std::int64_t>>();
    const std::string key = scale["key"];
    for (std::int64_t z = 0; z < size[2]; z += chunk[2])
      for (std::int64_t y = 0; y < size[1]; y += chunk[1])
        for (std::int64_t x = 0; x < size[0]; x += chunk[0]) {
          const auto span = [&](int a, std::int64_t lo) {
            return std::to_string(offset[a] + lo) + "-" + std::to_string(offset[a] + std::min(lo + chunk[a], size[a]));
          };
          const std::string file = span(0, x) + "_" + span(1, y) + "_" + span(2, z);
          save(folder / key / file, ok(api, root + key + "/" + file).body);
        }
  }
}

// Every file of /zarr/<name>/ saved under `folder`, chunk keys made from each .zarray.
void copy_zarr(Api& api, const std::string& name, const fs::path& folder) {
  const std::string root = "/zarr/" + name + "/";
  save(folder / ".zgroup", ok(api, root + ".zgroup").body);
  const HttpResponse attributes = ok(api, root + ".zattrs");
  save(folder / ".zattrs", attributes.body);
  const nlohmann::json multiscales = json_of(attributes)["multiscales"];
  for (const nlohmann::json& dataset : multiscales[0]["datasets"]) {
    const std::string level = dataset["path"];
    const HttpResponse array = ok(api, root + level + "/.zarray");
    save(folder / level / ".zarray", array.body);
    const auto shape = json_of(array)["shape"].get<std::vector<std::int64_t>>();
    const auto chunks = json_of(array)["chunks"].get<std::vector<std::int64_t>>();
    for (std::int64_t z = 0; z * chunks[0] < shape[0]; ++z)
      for (std::int64_t y = 0; y * chunks[1] < shape[1]; ++y)
        for (std::int64_t x = 0; x * chunks[2] < shape[2]; ++x) {
          const std::string key = level + "/" + std::to_string(z) + "/" + std::to_string(y) + "/" + std::to_string(x);
          save(folder / key, ok(api, root + key).body);
        }
  }
}

io::ReadOptions at_level(std::int64_t level) {
  io::ReadOptions options;
  options.level = level;
  return options;
}

void expect_same(const Volume& got, const Volume& expected, const std::string& what) {
  ASSERT_EQ(got.dims(), expected.dims()) << what;
  ASSERT_EQ(got.dtype(), expected.dtype()) << what;
  const auto differs = std::mismatch(got.bytes(), got.bytes() + got.byte_size(), expected.bytes());
  EXPECT_EQ(differs.first, got.bytes() + got.byte_size())
      << what << ": first difference at byte " << (differs.first - got.bytes()) << " of " << got.byte_size();
}

class ServerChunks : public SharedApiTest {
 protected:
  test::TempDir dir_;
};

TEST_F(ServerChunks, DatasetsAreListedWithStableNames) {
  const nlohmann::json list = json_of(ok(api(), "/api/datasets"));
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[kScalar]["slug"], "prisms");
  EXPECT_EQ(list[kLabels]["slug"], "cells");
  EXPECT_EQ(list[kPlain]["slug"], "sphere");
  EXPECT_EQ(ok(api(), "/api/datasets/cells/value?x=3&y=4&z=5").body,
            ok(api(), "/api/datasets/1/value?x=3&y=4&z=5").body);
}

TEST_F(ServerChunks, PrecomputedLevelsOfAScalarFileAreItsDecodedLevels) {
  copy_precomputed(api(), "prisms", dir_ / "prisms.precomputed");
  const nlohmann::json info = json_of(ok(api(), "/precomputed/prisms/info"));
  EXPECT_EQ(info["type"], "image");
  EXPECT_EQ(info["data_type"], "uint16");
  ASSERT_EQ(info["scales"].size(), 3u);
  for (int level = 0; level < 3; ++level) {
    const Volume expected = data().scalar_level(level, 8).converted(DType::u16);
    expect_same(io::read_volume(dir_ / "prisms.precomputed", at_level(level)), expected, "level " + std::to_string(level));
  }
}

TEST_F(ServerChunks, PrecomputedSegmentationHasExactIdsThenDominantLabels) {
  copy_precomputed(api(), "cells", dir_ / "cells.precomputed");
  const nlohmann::json info = json_of(ok(api(), "/precomputed/cells/info"));
  EXPECT_EQ(info["type"], "segmentation");
  EXPECT_EQ(info["scales"][0]["encoding"], "compressed_segmentation");
  expect_same(io::read_volume(dir_ / "cells.precomputed"), data().labels_source().converted(DType::u32), "level 0");
  expect_same(io::read_volume(dir_ / "cells.precomputed", at_level(2)),
              data().dominant_labels(2).converted(DType::u32), "level 2");
}

TEST_F(ServerChunks, OmeZarrLevelsAreTheDecodedLevelsInTheSourceType) {
  copy_zarr(api(), "prisms", dir_ / "prisms.ome.zarr");
  copy_zarr(api(), "cells", dir_ / "cells.ome.zarr");
  const nlohmann::json attributes = json_of(ok(api(), "/zarr/prisms/.zattrs"));
  EXPECT_EQ(attributes["multiscales"][0]["datasets"].size(), 3u);
  for (int level = 0; level < 3; ++level)
    expect_same(io::read_volume(dir_ / "prisms.ome.zarr", at_level(level)),
                data().scalar_level(level, 8).converted(DType::u16), "prisms level " + std::to_string(level));
  expect_same(io::read_volume(dir_ / "cells.ome.zarr"), data().labels_source(), "cells level 0");
  expect_same(io::read_volume(dir_ / "cells.ome.zarr", at_level(3)), data().dominant_labels(3), "cells level 3");
}

TEST_F(ServerChunks, RequestsOutsideTheViewsAreNotFound) {
  const nlohmann::json info = json_of(ok(api(), "/precomputed/cells/info"));
  const std::string key = info["scales"][0]["key"];
  for (const std::string& target : std::vector<std::string>{
           "/precomputed/cells/" + key + "/0-40_0-36_0-33", "/precomputed/cells/" + key + "/1-40_0-36_0-32",
        "/precomputed/cells/" + key + "/0-40_0-36_0-32x", "/precomputed/cells/" + key + "/-0-40_0-36_0-32",
        "/precomputed/cells/nokey/0-40_0-36_0-32", "/precomputed/cells/../prisms/info", "/precomputed/nobody/info",
        "/precomputed/1/info", "/zarr/cells/0/0/0/1", "/zarr/cells/0/00/0/0", "/zarr/cells/0/0/0", "/zarr/cells/0/0/0/0/0",
        "/zarr/cells/7/.zarray", "/zarr/cells/-1/.zarray", "/zarr/cells/0/99999999999999999999/0/0",
        "/zarr/cells/../../etc/passwd", "/zarr/sphere/.zattrs", "/precomputed/sphere/info", "/zarr/cells"}) {
    const HttpResponse r = get(api(), target);
    EXPECT_EQ(r.status, 404) << target << ": " << r.body;
  }
  EXPECT_EQ(post(api(), "/zarr/cells/.zattrs", "").status, 405);
  EXPECT_EQ(ok(api(), "/precomputed/cells/" + key + "/0-40_0-36_0-32").content_type, "application/octet-stream");
  // HEAD is answered as GET (the HTTP layer drops the body), as zarr clients probe with it.
  EXPECT_EQ(api().handle(make_request("HEAD", "/zarr/cells/0/.zarray")).status, 200);
}

TEST(ServerChunksCors, OffUnlessAnOriginIsGiven) {
  const auto closed = make_api();
  EXPECT_FALSE(get(*closed, "/zarr/cells/.zgroup").header("Access-Control-Allow-Origin"));
  EXPECT_NE(closed->handle(make_request("OPTIONS", "/zarr/cells/.zgroup")).status, 204);
  ApiOptions options;
  options.cors_origin = "https://neuroglancer-demo.appspot.com";
  const auto open = make_api(options);
  EXPECT_EQ(get(*open, "/zarr/cells/.zgroup").header("Access-Control-Allow-Origin"), options.cors_origin);
  EXPECT_EQ(get(*open, "/zarr/nobody/.zgroup").header("Access-Control-Allow-Origin"), options.cors_origin);
  const HttpResponse preflight = open->handle(make_request("OPTIONS", "/api/datasets/0/palette"));
  EXPECT_EQ(preflight.status, 204);
  EXPECT_TRUE(preflight.header("Access-Control-Allow-Methods"));
}

TEST(ServerChunksCors, OriginsThatAreNotOriginsAreRefused) {
  for (const std::string origin : {"*", "http://127.0.0.1:8080", "https://[::1]:9000", "https://example.org"}) {
    ApiOptions options;
    options.cors_origin = origin;
    EXPECT_NO_THROW(make_api(options)) << origin;
  }
  for (const std::string& origin : std::vector<std::string>{"example.org", "https://a.org/path", "https://a.org\r\nSet-Cookie: x=1",
                                   "http://", "ftp://a.org", "https://a b.org", std::string(300, 'a')}) {
    ApiOptions options;
    options.cors_origin = origin;
    EXPECT_EQ(test::parameter_of([&] { make_api(options); }), "ApiOptions::cors_origin") << origin;
  }
}

}  // namespace
}  // namespace strata::server
