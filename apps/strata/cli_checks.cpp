#include "cli_checks.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <system_error>

#include <fmt/format.h>

#include "strata/io/touched_paths.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::cli {

namespace fs = std::filesystem;

void as_usage_error(const std::function<void()>& check) {
  try {
    check();
  } catch (const UsageError&) {
    throw;
  } catch (const ParameterError& e) {
    throw UsageError(e.parameter(), e.problem());
  }
}

void naming_files(const std::vector<std::string>& files, const std::function<void()>& run) {
  try {
    run();
  } catch (const ParameterError&) {
    throw;
  } catch (const Error& e) {
    const std::string_view message = e.what();
    const bool named = message.starts_with("-") || std::any_of(files.begin(), files.end(), [&](const std::string& f) {
                         return !f.empty() && message.find(f) != std::string_view::npos;
                       });
    if (named || files.empty()) throw;
    throw Error(files.front() + ": " + std::string(message));
  }
}

namespace {

// What an option of CLI11's type name `type` ("INT", "FLOAT", "TEXT:{auto,bar}") takes.
std::string expected_value(const std::string& type) {
  const std::string base = type.substr(0, type.find(':'));
  if (base == "INT") return "an integer";
  if (base == "UINT") return "a non-negative integer";
  if (base == "FLOAT") return "a number";
  const std::size_t set = type.find('{');
  if (set != std::string::npos) return "one of " + type.substr(set);
  return "a value";
}

// Why `text` is no value of an option of CLI11's base type name `base` ("" when it is one);
// integers are rewritten without leading zeros.
std::string value_problem(const std::string& base, const std::string& expected, std::string& text) {
  if (text.empty()) return "expected " + expected + ", got an empty value";
  const std::string got = "expected " + expected + ", got '" + text + "'";
  if (base == "INT" || base == "UINT") {
    const bool sign = base == "INT" && (text[0] == '-' || text[0] == '+');
    const std::string digits = text.substr(sign ? 1 : 0);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) return got;
    // Decimal, as written: CLI11 would read "010" as octal 8 and "0x10" as 16.
    text = std::string(sign && text[0] == '-' ? "-" : "") +
           digits.substr(std::min(digits.find_first_not_of('0'), digits.size() - 1));
  } else if (base == "FLOAT") {
    char* end = nullptr;
    (void)std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size()) return got;
  }
  return {};
}

}  // namespace

void check_option_values(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (option->get_type_size_max() == 0) continue;  // a flag: it takes no value
    const std::string type = option->get_type_name();
    const std::string base = type.substr(0, type.find(':')), expected = expected_value(type);
    // First among the option's checks, so every option says the same about an empty value.
    option->transform(CLI::Validator(
        [base, expected](std::string& text) { return value_problem(base, expected, text); }, "", ""));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) check_option_values(*sub);
}

int check_rank_flag(int requested, int stored, const std::string& file) {
  if (requested < 0) as_usage_error([&] { ta::reconstruction_rank(requested, stored, file); });
  return ta::reconstruction_rank(requested, stored, file);
}

void check_finite_range(double value, double lo, double hi, const std::string& flag, std::string_view unit) {
  if (std::isfinite(value) && value >= lo && value <= hi) return;
  throw UsageError(flag, fmt::format("must be a finite number in [{}, {}]{}{}, got {}", lo, hi, unit.empty() ? "" : " ",
                                     unit, value));
}

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

// What the inputs read: each one's files (io::files_read: a detached header's data files, a raw
// file's sidecar, a folder with everything in it).
std::vector<io::TouchedPath> files_of_inputs(const std::vector<std::string>& inputs) {
  std::vector<io::TouchedPath> files;
  for (const std::string& input : inputs)
    if (!input.empty())
      for (io::TouchedPath& f : io::files_read(input)) files.push_back(std::move(f));
  return files;
}

void check_spares(const std::vector<io::TouchedPath>& outputs, const std::string& flag,
                  const std::vector<std::string>& inputs) {
  if (const auto why = io::overwrite_conflict(outputs, files_of_inputs(inputs))) throw UsageError(flag, *why);
}

void check_extension(const std::string& output, const std::string& flag,
                     std::initializer_list<std::string_view> extensions) {
  if (extensions.size() == 0) return;
  const std::string name = lower(fs::path(output).filename().string());
  std::string expected;
  for (std::string_view e : extensions) {
    if (name.size() > e.size() && name.ends_with(e)) return;
    expected += (expected.empty() ? "" : " or ") + std::string(e);
  }
  throw UsageError(flag, "'" + output + "': this command writes " + expected + " files, so the name must end with " +
                             expected);
}

// The folder a new entry `path` goes into exists and this process may write to it.
void check_parent_writable(const fs::path& path, const std::string& flag) {
  const fs::path parent = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  std::error_code ec;
  if (!fs::is_directory(parent, ec))
    throw Error(flag + ": cannot write '" + path.string() + "': the folder '" + parent.string() + "' does not exist");
  if (::access(parent.c_str(), W_OK | X_OK) != 0)
    throw Error(flag + ": cannot write '" + path.string() + "': the folder '" + parent.string() + "' is not writable");
}

}  // namespace

void check_spares_inputs(const std::vector<std::filesystem::path>& outputs, const std::string& flag,
                         const std::vector<std::string>& inputs) {
  std::vector<io::TouchedPath> written;
  for (const fs::path& output : outputs)
    for (io::TouchedPath& f : io::plain_file_written(output)) written.push_back(std::move(f));
  check_spares(written, flag, inputs);
}

void check_output_file(const std::string& output, const std::string& flag, const std::vector<std::string>& inputs,
                       std::initializer_list<std::string_view> extensions) {
  check_spares(io::plain_file_written(output), flag, inputs);
  check_extension(output, flag, extensions);
  std::error_code ec;
  if (fs::is_directory(output, ec)) throw Error(flag + ": '" + output + "' is a folder, expected a file name");
  check_parent_writable(output, flag);
}

const io::VolumeFormat& check_volume_output(const std::string& output, const std::string& flag,
                                           const std::vector<std::string>& inputs, const DType* dtype,
                                           const io::WriteOptions& write) {
  check_spares(io::files_written(output, write), flag, inputs);
  const io::VolumeFormat* format = nullptr;
  const fs::path file = io::split_output_container(output).first;  // out.h5:/group/name writes out.h5
  try {
    format = &io::output_format(file);
  } catch (const Error& e) {
    throw UsageError(flag, e.what());
  }
  if (!format->create_writer) throw UsageError(flag, "'" + output + "': the " + format->name + " format has no writer");
  if (dtype && !format->writes(*dtype))
    throw UsageError(flag, "'" + output + "': " + format->name + " cannot store " + std::string(dtype_name(*dtype)) +
                               " samples");
  std::error_code ec;
  if (!(!format->directory.empty() && fs::is_directory(file, ec))) check_parent_writable(file, flag);
  return *format;
}

void check_output_folder(const std::string& output, const std::string& flag, const std::vector<std::string>& inputs) {
  check_spares({io::touched_itself(output)}, flag, inputs);
  std::error_code ec;
  if (fs::exists(output, ec) && !fs::is_directory(output, ec))
    throw UsageError(flag, "'" + output + "' is a file, expected a folder");
  if (fs::exists(output, ec)) return;
  // The folder and any missing parents are created: the nearest existing ancestor must be writable.
  fs::path p = fs::path(output).lexically_normal();
  if (!p.has_filename()) p = p.parent_path();
  while (p.has_parent_path() && !fs::exists(p.parent_path(), ec)) p = p.parent_path();
  check_parent_writable(p, flag);
}

void check_distinct_outputs(const std::string& a, const std::string& flag_a, const std::string& b,
                            const std::string& flag_b) {
  std::error_code ec;
  const bool same = fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec) ||
                    (fs::exists(a, ec) && fs::equivalent(a, b, ec));
  if (same) throw UsageError(flag_b, "'" + b + "' is also the " + flag_a + " output; choose two different files");
}

OutputSet::~OutputSet() {
  if (committed_) return;
  std::error_code ec;
  for (const fs::path& p : written_) fs::remove(p, ec);
  if (!folder_.empty() && fs::is_empty(folder_, ec)) fs::remove(folder_, ec);
}

}  // namespace strata::cli
