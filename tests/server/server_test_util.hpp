#pragma once
// Helpers shared by the server tests: three small datasets written once per test program, an
// Api over them, and request/response shorthands. Free of Eigen (test_http_server.cpp includes
// it beside httplib.h); the data is made in server_test_util.cpp.
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "strata/core/volume.hpp"
#include "strata/render/image.hpp"
#include "strata/server/api.hpp"
#include "strata/server/http_message.hpp"

namespace strata::server::testing {

// Dataset ids of ServerData::files(), in that order.
inline constexpr int kScalar = 0;  // prisms 48x40x36 u16, TA brick 16 (core 12), rank 8: 3 levels
inline constexpr int kLabels = 1;  // voronoi 40x36x32, 12 cells, Mixture Graph: 7 mip levels
inline constexpr int kPlain = 2;   // sphere 24x20x16 f32 NRRD, held in memory

class ServerData {
 public:
  static const ServerData& get();  // made on first use, removed at exit
  std::vector<std::filesystem::path> files() const;
  const std::filesystem::path& dir() const { return dir_; }
  const Volume& scalar_source() const { return scalar_; }
  const Volume& labels_source() const { return labels_; }
  const Volume& plain_source() const { return plain_; }
  // The scalar dataset's level `level` decoded by the TA codec (ta::TaVolume::decode_box), as f32.
  Volume scalar_level(int level, int rank) const;
  // The label dataset's dominant labels of `level` (mixture::EncodedLabels::dominant_labels).
  Volume dominant_labels(int level) const;

 private:
  ServerData();
  std::filesystem::path dir_;
  Volume scalar_, labels_, plain_;
};

// An Api over ServerData's files (fresh caches).
std::unique_ptr<Api> make_api(ApiOptions options = {});

// A test suite sharing one Api over ServerData's files (made before its first test, removed after
// its last), so the caches warm up once per suite.
class SharedApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { api_ = make_api().release(); }
  static void TearDownTestSuite() {
    delete api_;
    api_ = nullptr;
  }
  Api& api() { return *api_; }
  const ServerData& data() { return ServerData::get(); }

 private:
  static Api* api_;
};

HttpResponse get(Api& api, const std::string& target);
HttpResponse post(Api& api, const std::string& target, const std::string& body);
nlohmann::json json_of(const HttpResponse& response);
// The X-Strata-Stats header as JSON (null when absent).
nlohmann::json stats_of(const HttpResponse& response);
// PNG bytes decoded (through a temporary file: render::read_png reads files).
render::Image png_of(const std::string& bytes);
// Width and height from a baseline JPEG's SOF0 marker; {0, 0} when there is none.
std::pair<int, int> jpeg_size(const std::string& bytes);
// Resident set size of this process in bytes (/proc/self/statm).
std::uint64_t resident_bytes();
// Polls `condition` until it holds (true) or `seconds` pass (false), so a broken server fails
// a test instead of hanging it.
bool eventually(const std::function<bool()>& condition, double seconds = 10);

}  // namespace strata::server::testing
