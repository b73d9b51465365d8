#include "error_exit.hpp"

#include <cstdio>
#include <exception>
#include <filesystem>
#include <new>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "strata/core/error.hpp"

namespace strata::cli {

int print_error(const CLI::App& app, const std::string& memory_hint) {
  try {
    throw;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "error: %s\n", cli_message(e, app).c_str());
    return 2;
  } catch (const ParameterError& e) {
    std::fprintf(stderr, "error: %s\n", cli_message(e, app).c_str());
    return 1;
  } catch (const OutOfMemoryError& e) {
    std::fprintf(stderr, "error: %s: %s\n", e.what(), memory_hint.c_str());
    return 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    const std::string command = running_command_name(app);
    std::fprintf(stderr, "error: out of memory while running '%s': %s\n", command.c_str(), memory_hint.c_str());
    return 1;
  } catch (const std::length_error&) {
    const std::string command = running_command_name(app);
    std::fprintf(stderr, "error: '%s' needs a buffer larger than this machine can address: %s\n", command.c_str(),
                 memory_hint.c_str());
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    const std::string path = e.path1().empty() ? std::string("a file") : e.path1().string();
    std::fprintf(stderr, "error: %s: %s\n", path.c_str(), e.code().message().c_str());
    return 1;
  } catch (const nlohmann::json::exception& e) {
    // Strata's words, not the JSON library's (whose text may quote the bytes it choked on).
    const std::string command = running_command_name(app);
    if (e.id == 316)
      std::fprintf(stderr, "error: '%s' cannot write its JSON report: a text in it (such as a file name) is not valid UTF-8\n",
                   command.c_str());
    else
      std::fprintf(stderr, "error: '%s' failed on a JSON value it did not expect (JSON library error %d); please report "
                   "this with the command line\n", command.c_str(), e.id);
    return 1;
  } catch (const std::exception& e) {
    // Library code reports through strata::Error; anything else is a failure it did not expect.
    std::fprintf(stderr, "error: '%s' failed unexpectedly (%s); please report this with the command line\n",
                 running_command_name(app).c_str(), e.what());
    return 1;
  }
}

}  // namespace strata::cli
