#pragma once
#include <stdexcept>
#include <string>

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

}  // namespace strata
