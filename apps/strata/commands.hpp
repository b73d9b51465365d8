#pragma once
// Each subcommand lives in its own file and registers itself on the CLI11 app.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/core/progress.hpp"

namespace strata::cli {

// Options shared by every subcommand (set before the subcommand's callback runs).
struct GlobalOptions {
  int threads = 0;                // 0 = hardware threads
  std::string progress = "auto";  // auto | bar | json | none
  std::string isa;                // empty = STRATA_ISA or the machine's widest
  std::unique_ptr<ProgressSink> make_progress() const { return make_progress_sink(parse_progress_mode(progress)); }
};

// The largest value of T as a flag's help and errors write it: 2^64-1, 2^63-1, 2147483647.
template <class T>
std::string integer_max_text() {
  if constexpr (sizeof(T) == 8) return std::is_signed_v<T> ? "2^63-1" : "2^64-1";
  else return std::to_string(std::numeric_limits<T>::max());
}

// Checks the text of a flag that sets a T before CLI11 converts it: digits only (CLI11 would wrap
// "-1" into an unsigned value, and its own NonNegativeNumber prints the range as a 300-digit
// double), at most T's largest value (CLI11 saturates 2^64 and more to 2^64-1), and read as
// decimal (CLI11 would read "010" as octal 8).
template <class T>
CLI::Validator non_negative_integer() {
  static_assert(std::is_integral_v<T>);
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos)
          return "must be a non-negative integer, got '" + text + "'";
        const std::string digits = text.substr(std::min(text.find_first_not_of('0'), text.size() - 1));
        const std::string max = std::to_string(std::numeric_limits<T>::max());
        if (digits.size() > max.size() || (digits.size() == max.size() && digits > max))
          return "expected an integer in [0, " + integer_max_text<T>() + "], got '" + text + "'";
        text = digits;
        return {};
      },
      "", "non-negative integer");
}

void register_info(CLI::App& app, const GlobalOptions& global);
void register_convert(CLI::App& app, const GlobalOptions& global);
void register_formats(CLI::App& app, const GlobalOptions& global);
void register_generate(CLI::App& app, const GlobalOptions& global);
void register_compare(CLI::App& app, const GlobalOptions& global);
void register_compress(CLI::App& app, const GlobalOptions& global);
void register_decompress(CLI::App& app, const GlobalOptions& global);
void register_eval(CLI::App& app, const GlobalOptions& global);
void register_labels(CLI::App& app, const GlobalOptions& global);
void register_demo(CLI::App& app, const GlobalOptions& global);
void register_render(CLI::App& app, const GlobalOptions& global);
void register_serve(CLI::App& app, const GlobalOptions& global);

// The message of a library ParameterError in command-line terms: its parameter name replaced
// by the flag that sets it in the running subcommand (or the app), when there is one
// (parameter_flags.cpp holds the table); otherwise e.what() unchanged.
std::string cli_message(const ParameterError& e, const CLI::App& app);

// The app and the subcommands this run parsed, outermost first.
std::vector<const CLI::App*> running_commands(const CLI::App& app);
// "compress", "labels encode": the subcommand this run parsed ("strata" before one was).
std::string running_command_name(const CLI::App& app);

}  // namespace strata::cli
