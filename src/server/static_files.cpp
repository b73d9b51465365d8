#include "server/static_files.hpp"

#include <array>
#include <utility>

#include "strata/io/file_names.hpp"

namespace strata::server::detail {

std::optional<EmbeddedFile> find_embedded(std::string_view path) {
  for (const EmbeddedFile& f : embedded_files())
    if (path == f.path) return f;
  return std::nullopt;
}

std::string content_type_of(std::string_view path) {
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 13> kTypes{{
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {io::kJsonExtension, "application/json"},
      {".svg", "image/svg+xml"},
      {io::kPngExtension, "image/png"},
      {".jpg", "image/jpeg"},
      {".ico", "image/x-icon"},
      {".txt", "text/plain; charset=utf-8"},
      {".md", "text/plain; charset=utf-8"},
      {".woff2", "font/woff2"},
      {".wasm", "application/wasm"},
  }};
  for (const auto& [ext, type] : kTypes)
    if (path.size() >= ext.size() && path.substr(path.size() - ext.size()) == ext) return std::string(type);
  return "application/octet-stream";
}

std::string_view missing_client_page() {
  return R"(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>Strata</title></head>
<body>
<h1>Strata server</h1>
<p>The viewer client is missing: this binary was built without the files of <code>web/</code>.
The HTTP API works; see <a href="/api/datasets">/api/datasets</a> and docs/viewer.md.</p>
</body></html>
)";
}

}  // namespace strata::server::detail
