#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "server/server_test_util.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/quant/scheme.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/ta_volume.hpp"
#include "support/test_support.hpp"

namespace strata::server::testing {

namespace {

Volume generated(gen::Kind kind, Extent dims, std::int64_t count, std::optional<DType> dtype = {}) {
  gen::Params p;
  p.kind = kind;
  p.dims = dims;
  p.seed = 5;
  p.count = count;
  p.output_dtype = dtype;
  return gen::generate(p);
}

test::TempDir& temp_dir() {
  static test::TempDir dir;
  return dir;
}

}  // namespace

ServerData::ServerData()
    : dir_(temp_dir().path()),
      scalar_(generated(gen::Kind::prisms, {48, 40, 36}, 0)),
      labels_(generated(gen::Kind::voronoi, {40, 36, 32}, 12)),
      plain_(generated(gen::Kind::sphere, {24, 20, 16}, 0)) {
  io::write_volume(dir_ / "prisms.nrrd", scalar_);
  ta::CompressParams params;
  params.layout = {16, 2};
  params.codec.rank = 8;
  params.codec.quant = quant::QuantScheme::parse("u16,b8log+");
  auto source = io::open_volume(dir_ / "prisms.nrrd");
  ta::compress_volume(*source, dir_ / "prisms.strata", params, silent_progress());
  std::filesystem::remove(dir_ / "prisms.nrrd");
  mixture::EncodeOptions options;
  options.measure_error = false;
  mixture::encode_labels(labels_, dir_ / "cells.strata", options);
  io::write_volume(dir_ / "sphere.nrrd", plain_);
}

const ServerData& ServerData::get() {
  static const ServerData data;
  return data;
}

std::vector<std::filesystem::path> ServerData::files() const {
  return {dir_ / "prisms.strata", dir_ / "cells.strata", dir_ / "sphere.nrrd"};
}

Volume ServerData::scalar_level(int level, int rank) const {
  const ta::TaVolume volume(dir_ / "prisms.strata");
  return volume.decode_box(level, Box::whole(volume.geometry().level(level).dims), rank);
}

Volume ServerData::dominant_labels(int level) const {
  return mixture::EncodedLabels(dir_ / "cells.strata").dominant_labels(level);
}

Api* SharedApiTest::api_ = nullptr;

std::unique_ptr<Api> make_api(ApiOptions options) { return std::make_unique<Api>(ServerData::get().files(), options); }

HttpResponse get(Api& api, const std::string& target) { return api.handle(make_request("GET", target)); }

HttpResponse post(Api& api, const std::string& target, const std::string& body) {
  return api.handle(make_request("POST", target, body));
}

nlohmann::json json_of(const HttpResponse& response) { return nlohmann::json::parse(response.body); }

nlohmann::json stats_of(const HttpResponse& response) {
  const auto header = response.header("X-Strata-Stats");
  return header ? nlohmann::json::parse(*header) : nlohmann::json();
}

render::Image png_of(const std::string& bytes) {
  test::TempDir dir;
  std::ofstream(dir / "image.png", std::ios::binary) << bytes;
  return render::read_png(dir / "image.png");
}

std::pair<int, int> jpeg_size(const std::string& b) {
  if (b.size() < 4 || std::uint8_t(b[0]) != 0xFF || std::uint8_t(b[1]) != 0xD8) return {0, 0};
  for (std::size_t i = 2; i + 9 < b.size();) {
    if (std::uint8_t(b[i]) != 0xFF) return {0, 0};
    const std::uint8_t marker = std::uint8_t(b[i + 1]);
    const std::size_t length = std::size_t(std::uint8_t(b[i + 2])) << 8 | std::uint8_t(b[i + 3]);
    if (marker == 0xC0 || marker == 0xC2) {
      const int h = std::uint8_t(b[i + 5]) << 8 | std::uint8_t(b[i + 6]);
      const int w = std::uint8_t(b[i + 7]) << 8 | std::uint8_t(b[i + 8]);
      return {w, h};
    }
    i += 2 + length;
  }
  return {0, 0};
}

std::uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  statm >> size >> resident;
  return resident * std::uint64_t(sysconf(_SC_PAGESIZE));
}

bool eventually(const std::function<bool()>& condition, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

}  // namespace strata::server::testing
