#pragma once
// How `strata` and `strata-mpi` report a failed command: one `error: …` line on stderr and the
// exit code (2 usage error, 1 anything else).
#include <CLI/CLI.hpp>

#include <string>

namespace strata::cli {

// Call inside a catch handler: prints the exception being handled (a ParameterError with the
// flag of the running subcommand, an out-of-memory with `memory_hint`) and returns the exit code.
int print_error(const CLI::App& app, const std::string& memory_hint);

}  // namespace strata::cli
