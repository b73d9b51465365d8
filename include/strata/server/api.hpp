#pragma once
/// @file
/// @brief The HTTP API of `strata serve` (docs/viewer.md) as a request router: a request in, a
/// response out, no sockets. The HTTP layer (http_server.hpp) and the tests drive it alike.
///
/// It serves only the datasets it was constructed with (addressed by their index or their
/// name: the file name without its extension, made unique) and the client files compiled into
/// the binary; no request reaches the filesystem outside them. Each .strata dataset is also a
/// Neuroglancer precomputed volume (`/precomputed/<name>/`) and an OME-Zarr image
/// (`/zarr/<name>/`), chunks decoded on request (docs/viewer.md). Every parameter
/// is validated (400 with {"error", "parameter"}); unknown datasets and paths are 404. Frames
/// go through a bounded RenderQueue (503 when full, 204 for superseded requests); slices, voxel
/// values, palettes and box queries run on the calling thread. Calls to one dataset's session
/// are serialised; handle() itself is thread-safe.
///
/// This header and the ones it includes stay free of Eigen, which must never meet httplib in
/// one translation unit (DESIGN.md, "Known traps").
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "strata/server/http_message.hpp"

namespace strata::server {

class RenderQueue;

/// @brief Server-wide settings of the API.
struct ApiOptions {
  /// Memory for the brick caches of all datasets (`--cache-mb`), split evenly among the .strata
  /// files; a TA dataset gives 3/4 of its share to reconstructed bricks and 1/4 to dequantized
  /// models. Plain volumes are held whole and label volumes keep their decoded node ids, on top.
  std::uint64_t cache_bytes = 1024ull << 20;
  std::size_t queue_capacity = 4;  ///< render jobs that may wait (RenderQueue)
  double coarse_fps = 15;          ///< quality=coarse frames aim at this rate (rendering; encoding and HTTP add ~10 ms)
  double coarse_min_scale = 2;     ///< quality=coarse casts at most 1/this rays per image edge
  int loader_threads = 0;          ///< per TA dataset; 0 = lod::default_loader_threads()
  /// Which volume of every file that holds several (render::SessionOptions::volume; `--volume`).
  std::optional<std::int64_t> volume;
  /// The origin (`https://host:port`, or `*`) whose pages may read the API from another site
  /// (`--cors`): sent as Access-Control-Allow-Origin on every response. Empty: no CORS headers,
  /// so browsers keep other sites' pages out.
  std::string cors_origin;
  /// 1..100: uint8 images in the precomputed view as `jpeg` chunks of this quality
  /// (`--precomputed-jpeg`); 0: `raw`. Other sample types and segmentations keep their encoding.
  int precomputed_jpeg_quality = 0;
  /// Told of each file found in a folder that does not open (DatasetFile::folder), with the
  /// reason, as it is skipped; such files are left out rather than stopping the server.
  std::function<void(const std::filesystem::path& file, const std::string& reason)> on_skip;
};

/// @brief A file to serve, and the folder argument it was found in (empty: named itself).
struct DatasetFile {
  std::filesystem::path path;
  std::filesystem::path folder;
};

class Api {
 public:
  /// @brief Opens every file (dataset i = files[i]). Throws Error naming a file that cannot be
  /// opened, ParameterError("files") when there is none.
  explicit Api(const std::vector<std::filesystem::path>& files, const ApiOptions& options = {});
  /// @brief Opens every file in order; dataset ids count the files that open. A file found in
  /// a folder that does not open is skipped (ApiOptions::on_skip hears of it); one named itself
  /// throws Error naming it, as does a list of which nothing opens ("nothing to serve").
  /// ParameterError("files") when the list is empty.
  explicit Api(const std::vector<DatasetFile>& files, const ApiOptions& options = {});
  ~Api();
  Api(const Api&) = delete;
  Api& operator=(const Api&) = delete;

  /// @brief The response to `request`; never throws (internal failures are 500 with a JSON
  /// error). Every response carries `Cache-Control: no-store`.
  HttpResponse handle(const HttpRequest& request);

  std::size_t dataset_count() const;
  /// @brief One line per dataset: id, name, kind and size (what `strata serve` prints).
  std::vector<std::string> summary() const;
  RenderQueue& render_queue();
  /// @brief Answers queued frames 503 and refuses new ones (shutdown).
  void stop_rendering();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief The dataset files named by command-line arguments, in order: a file as it is, a
/// folder as the volume files directly inside it, sorted by name (.strata, .nrrd, .nhdr, .nii,
/// .nii.gz, .tif, .tiff, and .raw with a FILE.raw.json or FILE.json sidecar; other files and
/// hidden ones are skipped), each with the folder it was found in. Throws Error for an argument
/// that does not exist or a folder without volumes.
std::vector<DatasetFile> dataset_files(const std::vector<std::string>& arguments);

}  // namespace strata::server
