#pragma once
// The viewer's files, compiled in from web/ by cmake/EmbedWeb.cmake (the generated
// web_assets.cpp defines embedded_files()). Requests are answered from this table only, so
// no request path ever reaches the filesystem.
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace strata::server::detail {

struct EmbeddedFile {
  const char* path;  // relative to web/, '/'-separated
  const unsigned char* data;
  std::size_t size;
};

std::span<const EmbeddedFile> embedded_files();

// The file at `path` (exact match: no normalisation, so "..", "." or "//" never match).
std::optional<EmbeddedFile> find_embedded(std::string_view path);
// Content type from the file name's extension (application/octet-stream when unknown).
std::string content_type_of(std::string_view path);
// The page `/` shows when the binary was built without web/ files.
std::string_view missing_client_page();

}  // namespace strata::server::detail
