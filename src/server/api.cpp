// The router of the API: datasets, paths, static files, errors (endpoints in api_render.cpp,
// api_views.cpp, api_labels.cpp; chunked views in api_chunks.cpp).
#include "strata/server/api.hpp"

#include <algorithm>
#include <cctype>
#include <fmt/format.h>

#include "server/api_detail.hpp"
#include "server/static_files.hpp"
#include "strata/core/error.hpp"
#include "strata/io/formats.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/store/container.hpp"

namespace strata::server {

using detail::ApiError;
using detail::Dataset;

namespace detail {

const mixture::BoxQuery& Dataset::box_query() {
  std::call_once(query_once_, [this] {
    const mixture::EncodedLabels& labels = session->labels();
    query_ = std::make_unique<mixture::BoxQuery>(labels, labels.lookup(), labels.label_map().size());
  });
  return *query_;
}

HttpResponse json_response(const nlohmann::json& body) {
  HttpResponse r;
  r.body = body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return r;
}

HttpResponse bytes_response(std::string content_type, const std::vector<std::uint8_t>& bytes) {
  HttpResponse r;
  r.content_type = std::move(content_type);
  r.body.assign(bytes.begin(), bytes.end());
  return r;
}

void require_kind(const Dataset& d, std::initializer_list<render::DatasetKind> kinds, const std::string& parameter) {
  const render::DatasetKind kind = d.session->kind();
  if (std::find(kinds.begin(), kinds.end(), kind) != kinds.end()) return;
  std::string names;
  for (render::DatasetKind k : kinds) names += (names.empty() ? "" : " or ") + std::string(render::dataset_kind_name(k));
  bad_parameter(parameter, fmt::format("applies to {} datasets; dataset {} is {}", names, d.id,
                                       render::dataset_kind_name(kind)));
}

std::shared_ptr<const render::TransferFunction> parse_tf(const std::string& text) {
  if (render::TransferFunction::is_preset(text))
    return std::make_shared<const render::TransferFunction>(render::TransferFunction::preset(text));
  try {
    return std::make_shared<const render::TransferFunction>(render::TransferFunction::from_points_text(text));
  } catch (const ParameterError& e) {
    bad_parameter("tf", "a preset name or v:r:g:b:a;...: " + e.problem());
  }
}

int parse_rank(const Params& p, const Dataset& d) {
  if (!p.has("rank")) return 0;
  require_kind(d, {render::DatasetKind::scalar}, "rank");
  return int(*p.integer("rank", 1, d.session->stored_rank()));
}

}  // namespace detail

struct Api::Impl {
  ApiOptions options;
  std::vector<std::unique_ptr<Dataset>> datasets;
  RenderQueue queue;

  Impl(const std::vector<DatasetFile>& files, const ApiOptions& o);
  HttpResponse route(const HttpRequest& r);
  HttpResponse list_datasets() const;
  HttpResponse dataset_endpoint(Dataset& d, const std::string& endpoint, const HttpRequest& r);
  HttpResponse chunked_view(std::string_view path, const HttpRequest& r);
  Dataset* dataset(std::string_view id) const;
};

namespace {

// `*` or an origin as browsers send it: http(s)://host[:port], no path and nothing a header line
// could be broken with (the value goes into every response as Access-Control-Allow-Origin).
void check_cors_origin(const std::string& origin) {
  if (origin.empty() || origin == "*") return;
  const std::size_t scheme = origin.starts_with("https://") ? 8 : origin.starts_with("http://") ? 7 : 0;
  const std::string_view host = std::string_view(origin).substr(scheme);
  const bool host_ok = !host.empty() && host.size() <= 253 && std::all_of(host.begin(), host.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' || c == '[' || c == ']';
  });
  if (scheme == 0 || !host_ok) {
    std::string shown = origin.size() > 80 ? origin.substr(0, 80) + "..." : origin;
    for (char& c : shown)
      if (std::iscntrl(static_cast<unsigned char>(c))) c = '?';  // no line breaks in the message
    throw ParameterError("ApiOptions::cors_origin",
                         fmt::format("expected * or an origin such as https://host:8443 (scheme, host, optional port; "
                                     "no path), got \"{}\"", shown));
  }
}

render::SessionOptions session_options(const ApiOptions& o, std::size_t strata_files) {
  const std::uint64_t share = o.cache_bytes / std::max<std::size_t>(1, strata_files);
  // A share must hold a useful cut of 32^3 bricks (128 KiB each), not just one brick.
  constexpr std::uint64_t kMinShare = 4ull << 20;
  if (share < kMinShare)
    throw ParameterError("ApiOptions::cache_bytes",
                         fmt::format("{} MiB cannot give each of the {} .strata files the {} MiB it needs at least",
                                     o.cache_bytes >> 20, strata_files, kMinShare >> 20));
  render::SessionOptions s;
  s.cache_bytes = share - share / 4;
  s.model_cache_bytes = share / 4;
  s.loader_threads = o.loader_threads;
  s.target_fps = o.coarse_fps;
  s.min_interactive_scale = o.coarse_min_scale;
  s.volume = o.volume;
  return s;
}

// A dataset's name in links: the file name without its format's extension (".strata", ".nii.gz"),
// characters other than letters, digits, '.', '_' and '-' replaced by '_', then "-2", "-3", ...
// appended while another dataset has it.
std::string dataset_name(const std::filesystem::path& file, const std::vector<std::unique_ptr<Dataset>>& taken) {
  std::string base = io::name_without_extension(file);
  for (char& c : base)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-') c = '_';
  if (base.empty() || base == "." || base == "..") base = "dataset";
  const auto used = [&](const std::string& n) {
    return std::any_of(taken.begin(), taken.end(), [&](const auto& d) { return d->name == n; });
  };
  std::string name = base;
  for (int n = 2; used(name); ++n) name = base + "-" + std::to_string(n);
  return name;
}

HttpResponse method_not_allowed(const std::string& allowed, const std::string& what) {
  HttpResponse e = error_response(405, "use " + allowed + " for " + what);
  e.set_header("Allow", allowed);
  return e;
}

std::string size_text(const nlohmann::json& d) {
  return fmt::format("{}x{}x{}", d["dims"][0].get<std::int64_t>(), d["dims"][1].get<std::int64_t>(),
                     d["dims"][2].get<std::int64_t>());
}

// Why `file` did not open: the message, without the file's name in front when it has it.
std::string open_failure(const std::filesystem::path& file, const std::exception& e) {
  std::string reason = e.what();
  const std::string prefix = file.string() + ": ";
  if (reason.starts_with(prefix)) reason.erase(0, prefix.size());
  return reason;
}

// "a, b and c".
std::string listed(const std::vector<std::string>& items) {
  std::string text;
  for (std::size_t i = 0; i < items.size(); ++i)
    text += (i == 0 ? "" : i + 1 == items.size() ? " and " : ", ") + items[i];
  return text;
}

}  // namespace

Api::Impl::Impl(const std::vector<DatasetFile>& files, const ApiOptions& o) : options(o), queue(o.queue_capacity) {
  if (files.empty()) throw ParameterError("files", "no volumes to serve");
  check_cors_origin(o.cors_origin);
  const std::size_t strata_files = std::size_t(
      std::count_if(files.begin(), files.end(), [](const DatasetFile& f) { return store::is_strata_file(f.path); }));
  const render::SessionOptions session = session_options(o, strata_files);
  std::vector<std::string> folders;
  for (const DatasetFile& file : files) {
    auto d = std::make_unique<Dataset>();
    try {
      d->session = std::make_unique<render::RenderSession>(file.path, session);
      d->description = d->session->describe();
    } catch (const std::exception& e) {
      // A file named on the command line was asked for; one of a folder's may be anything.
      if (file.folder.empty()) throw;
      if (options.on_skip) options.on_skip(file.path, open_failure(file.path, e));
      if (std::find(folders.begin(), folders.end(), file.folder.string()) == folders.end())
        folders.push_back(file.folder.string());
      continue;
    }
    d->id = int(datasets.size());
    d->name = dataset_name(file.path, datasets);
    d->path = file.path;
    d->description["id"] = d->id;
    d->description["slug"] = d->name;
    datasets.push_back(std::move(d));
  }
  if (datasets.empty()) throw Error("nothing to serve: no volume file in " + listed(folders) + " opens");
}

Dataset* Api::Impl::dataset(std::string_view id) const {
  for (const auto& d : datasets)
    if (d->name == id) return d.get();
  const auto index = detail::parse_integer(id);
  // Digits only: "+1", "01" and the like are not ids.
  if (!index || std::to_string(*index) != id || *index < 0 || *index >= std::int64_t(datasets.size())) return nullptr;
  return datasets[std::size_t(*index)].get();
}

HttpResponse Api::Impl::chunked_view(std::string_view path, const HttpRequest& r) {
  const bool precomputed = path.starts_with("/precomputed/");
  const std::string_view rest = path.substr(precomputed ? std::string_view("/precomputed/").size() : std::string_view("/zarr/").size());
  const std::size_t slash = rest.find('/');
  if (slash == std::string_view::npos) throw ApiError(404, "", "not found");
  Dataset* d = nullptr;
  for (const auto& candidate : datasets)
    if (candidate->name == rest.substr(0, slash)) d = candidate.get();
  // Names only: an index could name another file after a restart with other files.
  if (!d) throw ApiError(404, "name", "unknown dataset " + std::string(rest.substr(0, slash)));
  if (r.method != "GET" && r.method != "HEAD") return method_not_allowed("GET", "chunked views");
  detail::Params(r, {});
  const std::string_view file = rest.substr(slash + 1);
  return precomputed ? detail::precomputed_file(*d, file, options) : detail::zarr_file(*d, file, options);
}

HttpResponse Api::Impl::list_datasets() const {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& d : datasets) list.push_back(d->description);
  return detail::json_response(list);
}

HttpResponse Api::Impl::dataset_endpoint(Dataset& d, const std::string& endpoint, const HttpRequest& r) {
  const bool post = endpoint == "palette";
  if (endpoint != "render" && endpoint != "pick" && endpoint != "slice" && endpoint != "value" && endpoint != "query" &&
      !post)
    throw ApiError(404, "", "no such endpoint: " + endpoint);
  if (r.method != (post ? "POST" : "GET")) return method_not_allowed(post ? "POST" : "GET", endpoint);
  if (endpoint == "render") return detail::render_frame(d, queue, r);
  if (endpoint == "pick") return detail::pick_voxel(d, r);
  if (endpoint == "slice") return detail::slice_image(d, r);
  if (endpoint == "value") return detail::voxel_value(d, r);
  if (endpoint == "query") return detail::query_box(d, r);
  return detail::set_palette(d, r);
}

namespace {

HttpResponse static_file(std::string_view path) {
  const std::string_view rel = path == "/" ? std::string_view("index.html") : path.substr(std::string_view("/static/").size());
  if (const auto file = detail::find_embedded(rel)) {
    HttpResponse r;
    r.content_type = detail::content_type_of(rel);
    r.body.assign(reinterpret_cast<const char*>(file->data), file->size);
    return r;
  }
  if (path == "/") {
    HttpResponse r;
    r.content_type = "text/html; charset=utf-8";
    r.body = detail::missing_client_page();
    return r;
  }
  throw ApiError(404, "", "not found");
}

}  // namespace

HttpResponse Api::Impl::route(const HttpRequest& r) {
  const std::string& path = r.path;
  if (path == "/" || path.starts_with("/static/")) {
    if (r.method != "GET") return method_not_allowed("GET", "the client's files");
    return static_file(path);
  }
  if (path == "/api/datasets") {
    if (r.method != "GET") return method_not_allowed("GET", path);
    detail::Params(r, {});
    return list_datasets();
  }
  if (path.starts_with("/precomputed/") || path.starts_with("/zarr/")) return chunked_view(path, r);
  constexpr std::string_view prefix = "/api/datasets/";
  if (!path.starts_with(prefix)) throw ApiError(404, "", "not found");
  const std::string_view rest = std::string_view(path).substr(prefix.size());
  const std::size_t slash = rest.find('/');
  if (slash == std::string_view::npos) throw ApiError(404, "", "not found");
  Dataset* d = dataset(rest.substr(0, slash));
  if (!d) throw ApiError(404, "id", "unknown dataset " + std::string(rest.substr(0, slash)));
  return dataset_endpoint(*d, std::string(rest.substr(slash + 1)), r);
}

namespace {

// Library parameter names (ParameterError) as the API's query parameters.
std::string api_parameter(const std::string& library) {
  if (library == "SliceSpec::index") return "index";
  if (library == "SliceSpec::level" || library == "level") return "level";
  if (library == "voxel") return "x";
  if (library == "text") return "tf";
  return library;
}

}  // namespace

namespace {

std::vector<DatasetFile> named(const std::vector<std::filesystem::path>& files) {
  std::vector<DatasetFile> out;
  for (const std::filesystem::path& f : files) out.push_back({f, {}});
  return out;
}

}  // namespace

Api::Api(const std::vector<std::filesystem::path>& files, const ApiOptions& options) : Api(named(files), options) {}

Api::Api(const std::vector<DatasetFile>& files, const ApiOptions& options) : impl_(std::make_unique<Impl>(files, options)) {}

Api::~Api() = default;

HttpResponse Api::handle(const HttpRequest& request) {
  HttpResponse response;
  try {
    // A browser asks first before a page of another site sends a POST or custom headers.
    if (request.method == "OPTIONS" && !impl_->options.cors_origin.empty()) {
      response.status = 204;
      response.set_header("Access-Control-Allow-Methods", "GET, HEAD, POST");
      response.set_header("Access-Control-Allow-Headers", "Content-Type, Range");
    } else {
      response = impl_->route(request);
    }
  } catch (const ApiError& e) {
    response = error_response(e.status(), e.what(), e.parameter());
  } catch (const ParameterError& e) {
    response = error_response(400, e.what(), api_parameter(e.parameter()));
  } catch (const std::exception& e) {
    response = internal_error_response(e);
  }
  response.set_header("Cache-Control", "no-store");
  if (!impl_->options.cors_origin.empty()) response.set_header("Access-Control-Allow-Origin", impl_->options.cors_origin);
  return response;
}

std::size_t Api::dataset_count() const { return impl_->datasets.size(); }

std::vector<std::string> Api::summary() const {
  std::vector<std::string> lines;
  for (const auto& d : impl_->datasets)
    lines.push_back(fmt::format("{:3}  {:<16} {:<8} {:>14}  {}", d->id, d->name, d->description["kind"].get<std::string>(),
                                size_text(d->description), d->path.string()));
  return lines;
}

RenderQueue& Api::render_queue() { return impl_->queue; }

void Api::stop_rendering() { impl_->queue.stop(); }

}  // namespace strata::server
