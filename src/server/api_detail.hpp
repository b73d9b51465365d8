#pragma once
// What the endpoints of the API share (api.cpp routes; api_render.cpp, api_views.cpp and
// api_labels.cpp answer).
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/params.hpp"
#include "strata/mixture/box_query.hpp"
#include "strata/render/render_session.hpp"
#include "strata/server/api.hpp"
#include "strata/server/http_message.hpp"
#include "strata/server/render_queue.hpp"

namespace strata::server::detail {

struct ChunkViews;  // api_chunks.cpp

// One served file.
struct Dataset {
  int id = 0;
  std::string name;  // stable in links ("slug"): the file name without its extension, made unique
  std::filesystem::path path;
  std::unique_ptr<render::RenderSession> session;
  nlohmann::json description;  // GET /api/datasets entry, worked out once
  std::mutex mutex;            // session calls one at a time (RenderSession is not thread-safe)

  // Box queries only read the encoded labels, so they run outside `mutex` (BoxQuery is const
  // and thread-safe); built on the first query.
  const mixture::BoxQuery& box_query();
  // Its levels as precomputed and OME-Zarr volumes (api_chunks.cpp), built on first use;
  // `volume` picks the member of a volume set, as the session did.
  const ChunkViews& chunk_views(const ApiOptions& options);

 private:
  std::once_flag query_once_;
  std::unique_ptr<mixture::BoxQuery> query_;
  std::once_flag views_once_;
  std::shared_ptr<const ChunkViews> views_;
};

HttpResponse json_response(const nlohmann::json& body);
HttpResponse bytes_response(std::string content_type, const std::vector<std::uint8_t>& bytes);

// 400 naming `parameter` unless the dataset is of one of `kinds`.
void require_kind(const Dataset& d, std::initializer_list<render::DatasetKind> kinds, const std::string& parameter);
// The `tf` parameter: a preset name or the compact points text; never a file.
std::shared_ptr<const render::TransferFunction> parse_tf(const std::string& text);
// The `rank` parameter (scalar datasets only, 1..stored rank); 0 when absent.
int parse_rank(const Params& p, const Dataset& d);

HttpResponse render_frame(Dataset& d, RenderQueue& queue, const HttpRequest& r);
HttpResponse pick_voxel(Dataset& d, const HttpRequest& r);
HttpResponse slice_image(Dataset& d, const HttpRequest& r);
HttpResponse voxel_value(Dataset& d, const HttpRequest& r);
HttpResponse set_palette(Dataset& d, const HttpRequest& r);
HttpResponse query_box(Dataset& d, const HttpRequest& r);
// GET /precomputed/<name>/info and /precomputed/<name>/<key>/<chunk>: `rest` follows the name.
HttpResponse precomputed_file(Dataset& d, std::string_view rest, const ApiOptions& options);
// GET /zarr/<name>/.zgroup, .zattrs, <level>/.zarray, <level>/<z>/<y>/<x>: `rest` follows the name.
HttpResponse zarr_file(Dataset& d, std::string_view rest, const ApiOptions& options);

}  // namespace strata::server::detail
