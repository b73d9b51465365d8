// The viewer's HTTP API (server::Api, docs/viewer.md) called directly, without sockets: the
// router, every parameter parser and the endpoints behind them (datasets, render, slice, value,
// palette, query, static files, the precomputed and OME-Zarr chunked views), over three tiny
// datasets from fuzz/data: a TA-compressed scalar volume (id 0, slug "scalar"), its label
// volume (id 1, "labels") and a plain NRRD volume (id 2, "plain").
//
// Input: the request line "METHOD TARGET" (or just TARGET, a GET), a newline, then the body.
// The target is split and percent-decoded as the HTTP layer does (make_request). Api::handle
// never throws: an exception escaping it is a bug.
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "support.hpp"
#include "strata/server/api.hpp"

namespace {

strata::server::Api& api() {
  static const auto instance = [] {
    strata::server::ApiOptions options;
    options.cache_bytes = 64ull << 20;
    options.queue_capacity = 2;
    options.loader_threads = 1;
    const std::string dir = STRATA_FUZZ_DATA_DIR;
    return std::make_unique<strata::server::Api>(
        std::vector<std::filesystem::path>{dir + "/scalar.strata", dir + "/labels.strata", dir + "/plain.nrrd"}, options);
  }();
  return *instance;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  (void)api();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::size_t newline = text.find('\n');
  std::string_view line = text.substr(0, newline);
  const std::string body(newline == std::string_view::npos ? std::string_view() : text.substr(newline + 1));
  std::string method = "GET";
  if (const std::size_t space = line.find(' '); space != std::string_view::npos && !line.starts_with('/')) {
    method = std::string(line.substr(0, space));
    line = line.substr(space + 1);
  }
  strata::fuzz::run_guarded([&] { (void)api().handle(strata::server::make_request(method, line, body)); });
  return 0;
}
