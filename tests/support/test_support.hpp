#pragma once
// Helpers shared by all test programs: temporary directories and locating sample data.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace strata::test {

// A fresh directory under the system temp dir, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
 private:
  std::filesystem::path path_;
};

// `tests/data/<name>`: small fixtures kept in the repository (always present; see its NOTICE).
std::filesystem::path test_data(const std::string& name);
// `../shared/data/<name>` if present (tests on real data skip otherwise).
std::optional<std::filesystem::path> shared_data(const std::string& name);
// `/usr/share/mricron/templates/<name>` if the mricron-data package is installed.
std::optional<std::filesystem::path> mricron_data(const std::string& name);

// XORs one byte of a file in place (corruption tests).
void flip_byte(const std::filesystem::path& path, std::uint64_t offset);

// The message of the strata::Error that `f` throws; "" when it throws none.
std::string error_of(const std::function<void()>& f);
// The parameter() of the strata::ParameterError that `f` throws; "" when it throws none
// (any other exception propagates).
std::string parameter_of(const std::function<void()>& f);

// `path` in single quotes, for a shell command line.
std::string shell_quoted(const std::filesystem::path& path);

// Runs a shell command, capturing stdout+stderr; returns the exit code.
int run_command(const std::string& command, std::string* output = nullptr);

}  // namespace strata::test
