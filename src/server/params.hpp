#pragma once
// Validation of query parameters: every parameter of an endpoint is declared, parsed strictly
// (decimal, whole string, finite) and range-checked; a violation is an ApiError(400) naming the
// parameter, which the router turns into {"error", "parameter"}.
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/server/http_message.hpp"

namespace strata::server::detail {

// An answer other than 200 decided while handling a request.
class ApiError : public Error {
 public:
  ApiError(int status, std::string parameter, const std::string& message)
      : Error(message), status_(status), parameter_(std::move(parameter)) {}
  int status() const { return status_; }
  const std::string& parameter() const { return parameter_; }

 private:
  int status_;
  std::string parameter_;
};

// 400 naming `parameter`.
[[noreturn]] void bad_parameter(const std::string& parameter, const std::string& problem);

// A closed or open interval of allowed numbers.
struct NumberRange {
  double lo, hi;
  bool lo_open = false, hi_open = false;
  bool contains(double v) const { return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi); }
  std::string describe() const;
};

class Params {
 public:
  // Throws ApiError(400) for a parameter not in `allowed` or given twice.
  Params(const HttpRequest& request, std::initializer_list<std::string_view> allowed);

  bool has(std::string_view name) const { return find(name) != nullptr; }
  std::optional<std::string> text(std::string_view name) const;
  std::string required_text(std::string_view name) const;
  // Integers: decimal digits with an optional '-', within [lo, hi].
  std::optional<std::int64_t> integer(std::string_view name, std::int64_t lo, std::int64_t hi) const;
  std::int64_t integer(std::string_view name, std::int64_t lo, std::int64_t hi, std::int64_t fallback) const;
  std::int64_t required_integer(std::string_view name, std::int64_t lo, std::int64_t hi) const;
  // Finite decimal numbers within `range`.
  std::optional<double> number(std::string_view name, const NumberRange& range) const;
  double number(std::string_view name, const NumberRange& range, double fallback) const;
  double required_number(std::string_view name, const NumberRange& range) const;
  // Exactly `count` comma-separated finite numbers / integers.
  std::optional<std::vector<double>> numbers(std::string_view name, std::size_t count) const;
  std::optional<std::vector<std::int64_t>> integers(std::string_view name, std::size_t count) const;
  // One of `choices`; `fallback` when absent.
  std::string choice(std::string_view name, std::initializer_list<std::string_view> choices,
                     std::string_view fallback) const;

 private:
  const std::string* find(std::string_view name) const;
  const HttpRequest& request_;
};

// Strict parsers (whole string, decimal); nullopt when malformed.
std::optional<std::int64_t> parse_integer(std::string_view text);
std::optional<double> parse_number(std::string_view text);

}  // namespace strata::server::detail
