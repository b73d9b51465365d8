#include "strata/store/metadata_json.hpp"

#include <cmath>

#include <fmt/format.h>

#include "strata/core/error.hpp"

namespace strata::store {

namespace {

// What a JSON value is, for "expected …, got …" messages.
std::string found(const nlohmann::json& value) {
  return value.is_null() ? std::string("null") : fmt::format("{} {}", value.type_name(), json_excerpt(value));
}

}  // namespace

void MetadataField::fail(const std::string& problem) const { throw FormatError(file, path, problem); }

std::string json_excerpt(const nlohmann::json& value, std::size_t limit) {
  std::string text = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (text.size() > limit) text = text.substr(0, limit) + "…";
  return text;
}

const nlohmann::json& json_member(const nlohmann::json& object, std::string_view key, const MetadataField& field) {
  const MetadataField member = field / key;
  if (!object.is_object()) field.fail("expected an object with the key \"" + std::string(key) + "\", got " + found(object));
  const auto it = object.find(key);
  if (it == object.end()) member.fail("missing");
  return *it;
}

const nlohmann::json& json_object(const nlohmann::json& value, const MetadataField& field) {
  if (!value.is_object()) field.fail("expected an object, got " + found(value));
  return value;
}

std::int64_t json_integer(const nlohmann::json& value, const MetadataField& field, std::int64_t lo, std::int64_t hi) {
  const auto range = [&] { return fmt::format("an integer in [{}, {}]", lo, hi); };
  if (value.is_number_unsigned()) {
    const auto v = value.get<std::uint64_t>();
    if (v > std::uint64_t(std::numeric_limits<std::int64_t>::max()) || std::int64_t(v) > hi)
      field.fail(fmt::format("expected {}, got {}", range(), v));
    if (std::int64_t(v) < lo) field.fail(fmt::format("expected {}, got {}", range(), v));
    return std::int64_t(v);
  }
  if (!value.is_number_integer()) field.fail(fmt::format("expected {}, got {}", range(), found(value)));
  const auto v = value.get<std::int64_t>();
  if (v < lo || v > hi) field.fail(fmt::format("expected {}, got {}", range(), v));
  return v;
}

std::uint64_t json_unsigned(const nlohmann::json& value, const MetadataField& field, std::uint64_t hi) {
  if (!value.is_number_unsigned() || value.get<std::uint64_t>() > hi)
    field.fail(fmt::format("expected an integer in [0, {}], got {}", hi, found(value)));
  return value.get<std::uint64_t>();
}

double json_number(const nlohmann::json& value, const MetadataField& field) {
  if (!value.is_number()) field.fail("expected a finite number, got " + found(value));
  const double v = value.get<double>();
  if (!std::isfinite(v)) field.fail("expected a finite number, got " + found(value));
  return v;
}

std::string json_string(const nlohmann::json& value, const MetadataField& field) {
  if (!value.is_string()) field.fail("expected a string, got " + found(value));
  return value.get<std::string>();
}

bool json_bool(const nlohmann::json& value, const MetadataField& field) {
  if (!value.is_boolean()) field.fail("expected true or false, got " + found(value));
  return value.get<bool>();
}

// Arrays are reported as a whole: "metadata.source.dims: expected an array of 3 integers in
// [1, 2147483647], got [64,64,"a"]" names the field a user looks for and shows every element.
std::vector<std::int64_t> json_integers(const nlohmann::json& value, std::size_t n, const MetadataField& field,
                                        std::int64_t lo, std::int64_t hi) {
  const auto fail = [&] { field.fail(fmt::format("expected an array of {} integers in [{}, {}], got {}", n, lo, hi, found(value))); };
  if (!value.is_array() || value.size() != n) fail();
  std::vector<std::int64_t> out;
  for (const auto& v : value) {
    if (v.is_number_unsigned() ? v.get<std::uint64_t>() > std::uint64_t(hi) || std::int64_t(v.get<std::uint64_t>()) < lo
                               : !v.is_number_integer() || v.get<std::int64_t>() < lo || v.get<std::int64_t>() > hi)
      fail();
    out.push_back(v.get<std::int64_t>());
  }
  return out;
}

namespace {

std::vector<double> numbers(const nlohmann::json& value, std::size_t n, const MetadataField& field, bool positive) {
  const auto fail = [&] {
    field.fail(fmt::format("expected an array of {} finite numbers{}, got {}", n, positive ? " > 0" : "", found(value)));
  };
  if (!value.is_array() || value.size() != n) fail();
  std::vector<double> out;
  for (const auto& v : value) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || (positive && !(v.get<double>() > 0))) fail();
    out.push_back(v.get<double>());
  }
  return out;
}

}  // namespace

std::vector<double> json_numbers(const nlohmann::json& value, std::size_t n, const MetadataField& field) {
  return numbers(value, n, field, false);
}

std::vector<double> json_positive_numbers(const nlohmann::json& value, std::size_t n, const MetadataField& field) {
  return numbers(value, n, field, true);
}

}  // namespace strata::store
