#include "server/params.hpp"

#include <charconv>
#include <cmath>
#include <fmt/format.h>

namespace strata::server::detail {

void bad_parameter(const std::string& parameter, const std::string& problem) {
  throw ApiError(400, parameter, parameter + ": " + problem);
}

std::string NumberRange::describe() const {
  return fmt::format("{}{}, {}{}", lo_open ? "(" : "[", lo, hi, hi_open ? ")" : "]");
}

std::optional<std::int64_t> parse_integer(std::string_view text) {
  std::int64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return v;
}

std::optional<double> parse_number(std::string_view text) {
  double v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end || !std::isfinite(v)) return std::nullopt;
  return v;
}

namespace {

std::vector<std::string_view> split_commas(std::string_view text) {
  std::vector<std::string_view> parts;
  for (std::size_t start = 0;;) {
    const std::size_t comma = text.find(',', start);
    parts.push_back(text.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) return parts;
    start = comma + 1;
  }
}

}  // namespace

Params::Params(const HttpRequest& request, std::initializer_list<std::string_view> allowed) : request_(request) {
  for (auto it = request.params.begin(); it != request.params.end(); ++it) {
    bool known = false;
    for (std::string_view a : allowed) known = known || a == it->first;
    if (!known) bad_parameter(it->first, "unknown parameter for this endpoint");
    if (request.params.count(it->first) > 1) bad_parameter(it->first, "given more than once");
  }
}

const std::string* Params::find(std::string_view name) const {
  const auto it = request_.params.find(std::string(name));
  return it == request_.params.end() ? nullptr : &it->second;
}

std::optional<std::string> Params::text(std::string_view name) const {
  const std::string* v = find(name);
  return v ? std::optional<std::string>(*v) : std::nullopt;
}

std::string Params::required_text(std::string_view name) const {
  const std::string* v = find(name);
  if (!v) bad_parameter(std::string(name), "required");
  return *v;
}

std::optional<std::int64_t> Params::integer(std::string_view name, std::int64_t lo, std::int64_t hi) const {
  const std::string* v = find(name);
  if (!v) return std::nullopt;
  const auto parsed = parse_integer(*v);
  if (!parsed || *parsed < lo || *parsed > hi)
    bad_parameter(std::string(name), fmt::format("expected an integer in {}..{}", lo, hi));
  return parsed;
}

std::int64_t Params::integer(std::string_view name, std::int64_t lo, std::int64_t hi, std::int64_t fallback) const {
  return integer(name, lo, hi).value_or(fallback);
}

std::int64_t Params::required_integer(std::string_view name, std::int64_t lo, std::int64_t hi) const {
  if (!has(name)) bad_parameter(std::string(name), fmt::format("required (an integer in {}..{})", lo, hi));
  return *integer(name, lo, hi);
}

double Params::required_number(std::string_view name, const NumberRange& range) const {
  if (!has(name)) bad_parameter(std::string(name), "required (a number in " + range.describe() + ")");
  return *number(name, range);
}

std::optional<double> Params::number(std::string_view name, const NumberRange& range) const {
  const std::string* v = find(name);
  if (!v) return std::nullopt;
  const auto parsed = parse_number(*v);
  if (!parsed || !range.contains(*parsed))
    bad_parameter(std::string(name), "expected a finite number in " + range.describe());
  return parsed;
}

double Params::number(std::string_view name, const NumberRange& range, double fallback) const {
  return number(name, range).value_or(fallback);
}

namespace {

// Exactly `count` comma-separated values that `parse` accepts; 400 naming `name` otherwise.
template <class T, class Parse>
std::vector<T> parse_list(const std::string& text, std::size_t count, Parse parse, const std::string& name,
                          const char* what) {
  const std::vector<std::string_view> parts = split_commas(text);
  std::vector<T> out;
  for (std::string_view part : parts)
    if (const auto v = parse(part)) out.push_back(*v);
  if (parts.size() != count || out.size() != count)
    bad_parameter(name, fmt::format("expected {} comma-separated {}", count, what));
  return out;
}

}  // namespace

std::optional<std::vector<double>> Params::numbers(std::string_view name, std::size_t count) const {
  const std::string* v = find(name);
  if (!v) return std::nullopt;
  return parse_list<double>(*v, count, parse_number, std::string(name), "finite numbers");
}

std::optional<std::vector<std::int64_t>> Params::integers(std::string_view name, std::size_t count) const {
  const std::string* v = find(name);
  if (!v) return std::nullopt;
  return parse_list<std::int64_t>(*v, count, parse_integer, std::string(name), "integers");
}

std::string Params::choice(std::string_view name, std::initializer_list<std::string_view> choices,
                           std::string_view fallback) const {
  const std::string* v = find(name);
  if (!v) return std::string(fallback);
  std::string list;
  for (std::string_view c : choices) {
    if (*v == c) return *v;
    list += (list.empty() ? "" : ", ") + std::string(c);
  }
  bad_parameter(std::string(name), "expected one of " + list);
}

}  // namespace strata::server::detail
