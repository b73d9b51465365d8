#include "support/test_support.hpp"

#include "strata/core/error.hpp"

#include <array>
#include <cstdio>
#include <fstream>
#include <random>
#include <sys/wait.h>

namespace strata::test {

TempDir::TempDir() {
  std::random_device rd;
  for (int attempt = 0; attempt < 100; ++attempt) {
    auto candidate = std::filesystem::temp_directory_path() / ("strata-test-" + std::to_string(rd()));
    if (std::filesystem::create_directory(candidate)) {
      path_ = candidate;
      return;
    }
  }
  throw std::runtime_error("TempDir: could not create a temporary directory");
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::filesystem::path test_data(const std::string& name) {
  std::filesystem::path p = std::filesystem::path(STRATA_TEST_DATA_DIR) / name;
  if (!std::filesystem::exists(p)) throw std::runtime_error("test fixture missing: " + p.string());
  return p;
}

std::optional<std::filesystem::path> shared_data(const std::string& name) {
  std::filesystem::path p = std::filesystem::path(STRATA_SHARED_DATA_DIR) / name;
  if (std::filesystem::exists(p)) return p;
  return std::nullopt;
}

std::optional<std::filesystem::path> mricron_data(const std::string& name) {
  std::filesystem::path p = std::filesystem::path("/usr/share/mricron/templates") / name;
  if (std::filesystem::exists(p)) return p;
  return std::nullopt;
}

void flip_byte(const std::filesystem::path& path, std::uint64_t offset) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(std::streamoff(offset));
  char c;
  f.read(&c, 1);
  c = char(c ^ 0x5a);
  f.seekp(std::streamoff(offset));
  f.write(&c, 1);
}

int run_command(const std::string& command, std::string* output) {
  std::string full = command + " 2>&1";
  FILE* pipe = popen(full.c_str(), "r");
  if (!pipe) return -1;
  std::array<char, 4096> buffer;
  std::string text;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) text.append(buffer.data(), n);
  int status = pclose(pipe);
  if (output) *output = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

namespace {

// `describe` applied to the E that `f` throws; "" when it throws none.
template <class E, class Describe>
std::string described_error(const std::function<void()>& f, Describe describe) {
  try {
    f();
  } catch (const E& e) {
    return describe(e);
  }
  return "";
}

}  // namespace

std::string error_of(const std::function<void()>& f) {
  return described_error<Error>(f, [](const Error& e) { return std::string(e.what()); });
}

std::string parameter_of(const std::function<void()>& f) {
  return described_error<ParameterError>(f, [](const ParameterError& e) { return e.parameter(); });
}

std::string shell_quoted(const std::filesystem::path& path) {
  std::string s(1, '\'');  // built piecewise: GCC 12 reports a false -Wrestrict for "'" + ... + "'"
  s += path.string();
  s += '\'';
  return s;
}

}  // namespace strata::test
