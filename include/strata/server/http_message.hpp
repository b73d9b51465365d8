#pragma once
/// @file
/// @brief HTTP requests and responses as plain values, so the API can be driven and tested
/// without sockets; the HTTP layer (http_server.hpp) converts to and from the wire.
#include <exception>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace strata::server {

/// @brief A request as the router sees it: the path and the query parameters percent-decoded.
struct HttpRequest {
  std::string method = "GET";
  std::string path;
  std::multimap<std::string, std::string> params;
  std::string body;
};

/// @brief A response: status, content type, extra headers and the body bytes.
struct HttpResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body;

  /// @brief The value of header `name` (case-insensitive), if set.
  std::optional<std::string> header(std::string_view name) const;
  void set_header(std::string name, std::string value) { headers.emplace_back(std::move(name), std::move(value)); }
};

/// @brief `%XX` escapes decoded (and `+` as a space when `plus_is_space`, as in query strings).
/// Malformed escapes are kept as they are.
std::string percent_decode(std::string_view text, bool plus_is_space);
/// @brief A request for `target` ("/path?a=1&b=2"), split and decoded as the HTTP layer does.
HttpRequest make_request(std::string method, std::string_view target, std::string body = {});

/// @brief A JSON error body {"error": message, "parameter": parameter} (the parameter omitted
/// when empty) with `status`.
HttpResponse error_response(int status, const std::string& message, const std::string& parameter = {});

/// @brief The 500 answer to a request that failed with `e`. A strata::Error's message is ours
/// (it names the file and the field) and is sent; any other exception's text is a library's and
/// may quote anything, so the client gets "internal error while answering the request" (out of
/// memory says so) and never that text.
HttpResponse internal_error_response(const std::exception& e);

}  // namespace strata::server
