#include "strata/server/http_message.hpp"

#include <algorithm>
#include <cctype>

#include <new>

#include <nlohmann/json.hpp>

#include "strata/core/error.hpp"

namespace strata::server {

namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool same_name(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

}  // namespace

std::optional<std::string> HttpResponse::header(std::string_view name) const {
  for (const auto& [key, value] : headers)
    if (same_name(key, name)) return value;
  return std::nullopt;
}

std::string percent_decode(std::string_view text, bool plus_is_space) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '%' && i + 2 < text.size()) {
      const int hi = hex_digit(text[i + 1]), lo = hex_digit(text[i + 2]);
      if (hi >= 0 && lo >= 0) {
        out += char(hi * 16 + lo);
        i += 2;
        continue;
      }
    }
    out += plus_is_space && c == '+' ? ' ' : c;
  }
  return out;
}

HttpRequest make_request(std::string method, std::string_view target, std::string body) {
  HttpRequest r;
  r.method = std::move(method);
  r.body = std::move(body);
  const std::size_t q = target.find('?');
  r.path = percent_decode(target.substr(0, q), false);
  if (q == std::string_view::npos) return r;
  std::string_view query = target.substr(q + 1);
  while (!query.empty()) {
    const std::size_t amp = std::min(query.find('&'), query.size());
    const std::string_view pair = query.substr(0, amp);
    if (!pair.empty()) {
      const std::size_t eq = pair.find('=');
      const std::string_view key = pair.substr(0, eq);
      const std::string_view value = eq == std::string_view::npos ? std::string_view() : pair.substr(eq + 1);
      r.params.emplace(percent_decode(key, true), percent_decode(value, true));
    }
    query.remove_prefix(std::min(query.size(), amp + 1));
  }
  return r;
}

HttpResponse error_response(int status, const std::string& message, const std::string& parameter) {
  HttpResponse r;
  r.status = status;
  nlohmann::json body{{"error", message}};
  if (!parameter.empty()) body["parameter"] = parameter;
  // Messages may quote request bytes that are not UTF-8: replace those rather than throw.
  r.body = body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return r;
}

HttpResponse internal_error_response(const std::exception& e) {
  if (dynamic_cast<const Error*>(&e)) return error_response(500, e.what());
  if (dynamic_cast<const std::bad_alloc*>(&e)) return error_response(500, "out of memory while answering the request");
  return error_response(500, "internal error while answering the request");
}

}  // namespace strata::server
