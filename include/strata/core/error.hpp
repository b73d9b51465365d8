#pragma once
#include <stdexcept>
#include <string>
#include <utility>

namespace strata {

// The one exception type of the library. Messages name the file, the field and what was
// expected, so a user can fix the input without reading the code.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// Thrown for malformed or inconsistent input files: "<file>: <field>: <problem>".
class FormatError : public Error {
 public:
  FormatError(const std::string& file, const std::string& field, const std::string& problem)
      : Error(file + ": " + field + ": " + problem) {}
};

/// @brief Thrown when a buffer whose size the input or the caller decides cannot be allocated:
/// "<what>: cannot allocate <bytes> bytes for <shape> (out of memory)". Front ends report it as
/// running out of memory (Python: MemoryError) with the message unchanged.
class OutOfMemoryError : public Error {
 public:
  using Error::Error;
};

/// @brief Thrown when a value the caller passed to the library is out of range or inconsistent:
/// "<parameter>: <problem>", e.g. "CodecParams::rank: must be between 1 and the brick width 16, got 20".
///
/// `parameter()` names the value the way the caller set it through the library API, never as a
/// command-line flag:
///  - a field of an options struct is "<Struct>::<field>", with the struct that declares the
///    field: "CodecParams::rank", "BrickLayout::brick", "CompressParams::memory_limit",
///    "RenderOptions::step", "ReadOptions::raw_dims";
///  - a function argument is its name in the public header: "level", "box",
///    "preset_or_path", "progress_mode".
/// `problem()` is the message without that prefix. Front ends map `parameter()` to their own
/// option names: the strata CLI rewrites the prefix as the flag of the running subcommand.
class ParameterError : public Error {
 public:
  ParameterError(std::string parameter, const std::string& problem)
      : Error(parameter + ": " + problem), parameter_(std::move(parameter)) {}

  const std::string& parameter() const { return parameter_; }
  std::string problem() const { return std::string(what()).substr(parameter_.size() + 2); }

 private:
  std::string parameter_;
};

}  // namespace strata
