#include "error_exit.hpp"

#include <cstdio>
#include <exception>
#include <filesystem>
#include <new>
#include <stdexcept>

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
  } catch (const std::exception& e) {
    // Library code reports through strata::Error; anything else is a failure it did not expect.
    std::fprintf(stderr, "error: '%s' failed unexpectedly (%s); please report this with the command line\n",
                 running_command_name(app).c_str(), e.what());
    return 1;
  }
}

}  // namespace strata::cli
