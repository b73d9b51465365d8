// `strata serve FILE|DIR... [--host 127.0.0.1] [--port 8080] [--cache-mb N]`: the viewer's HTTP
// API (docs/viewer.md) over the named volumes, with the browser client compiled in.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/server/api.hpp"
#include "strata/server/http_server.hpp"

namespace strata::cli {

namespace {

struct ServeArgs {
  std::vector<std::string> inputs;
  std::string host = "127.0.0.1";
  int port = 8080;
  std::uint64_t cache_mb = 1024;
  std::size_t queue = 4;
  std::optional<std::int64_t> volume;
  std::string cors;
  int precomputed_jpeg = 0;
};

void run_serve(const ServeArgs& a, const GlobalOptions&) {
  const std::vector<server::DatasetFile> files = server::dataset_files(a.inputs);
  server::ApiOptions options;
  options.cache_bytes = a.cache_mb << 20;
  options.queue_capacity = a.queue;
  options.volume = a.volume;
  options.cors_origin = a.cors;
  options.precomputed_jpeg_quality = a.precomputed_jpeg;
  options.on_skip = [](const std::filesystem::path& file, const std::string& reason) {
    std::fprintf(stderr, "warning: skipping %s: %s\n", file.string().c_str(), reason.c_str());
  };
  std::printf("Opening %zu dataset%s\n", files.size(), files.size() == 1 ? "" : "s");
  const auto api_or_usage_error = [&] {
    try {
      return std::make_unique<server::Api>(files, options);
    } catch (const ParameterError& e) {
      if (e.parameter() == "ApiOptions::cors_origin") throw UsageError("--cors", e.problem());
      throw;
    }
  };
  const std::unique_ptr<server::Api> api_owner = api_or_usage_error();
  server::Api& api = *api_owner;
  for (const std::string& line : api.summary()) std::printf("  %s\n", line.c_str());
  server::ServerOptions http;
  http.host = a.host;
  http.port = a.port;
  server::HttpServer server(api, http);
  server.bind();
  std::printf("Serving on %s  (Ctrl-C stops)\n", server.url().c_str());
  std::string root = server.url();
  if (root.ends_with('/')) root.pop_back();
  std::printf("Neuroglancer: precomputed://%s/precomputed/<slug>   OME-Zarr: %s/zarr/<slug>\n", root.c_str(), root.c_str());
  std::fflush(stdout);
  server::serve_until_signal(server);
  std::printf("Stopped\n");
}

}  // namespace

void register_serve(CLI::App& app, const GlobalOptions& global) {
  auto a = std::make_shared<ServeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "serve",
      "Serve volumes to the browser viewer over HTTP (docs/viewer.md): server-side 3D frames, slices, voxel values, "
      "label palettes and box queries");
  cmd->add_option("inputs", a->inputs,
                  "Volume files (.strata, .nrrd, .nhdr, .nii, .nii.gz, .tif, .tiff, .raw with a .json sidecar) or "
                  "folders (the volume files directly inside); dataset ids follow this order")
      ->required();
  cmd->add_option("--host", a->host, "Address to listen on (loopback by default: other machines cannot connect)")
      ->capture_default_str();
  cmd->add_option("--port", a->port, "TCP port (0 = any free port)")->capture_default_str()->check(CLI::Range(0, 65535));
  cmd->add_option("--cache-mb", a->cache_mb,
                  "Memory for the brick caches of all datasets in MiB, split among the .strata files (plain volumes "
                  "are held whole on top)")
      ->capture_default_str()
      ->check(CLI::Range(16, 1 << 20));
  cmd->add_option("--queue", a->queue, "Frames that may wait for the renderer; more get 503 Retry-After: 1")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  cmd->add_option("--cors", a->cors,
                  "Let pages of this origin (https://host:port, or *) read the server from another site, e.g. a "
                  "Neuroglancer client served elsewhere (off by default)");
  cmd->add_option("--precomputed-jpeg", a->precomputed_jpeg,
                  "Serve 8-bit images in the Neuroglancer precomputed view as JPEG chunks of this quality (1-100): "
                  "lossy, several times fewer bytes to send (default: raw)")
      ->check(CLI::Range(1, 100));
  add_volume_option(*cmd, a->volume);
  cmd->callback([a, &global] { run_serve(*a, global); });
}

}  // namespace strata::cli
