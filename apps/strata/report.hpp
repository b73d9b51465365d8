#pragma once
// Small helpers shared by subcommands: raw-input flags and human-readable numbers.
#include <CLI/CLI.hpp>

#include <string>

#include "strata/io/volume_io.hpp"

namespace strata::cli {

// --dims/--dtype/--spacing/--big-endian for raw inputs without a JSON sidecar.
struct RawInputArgs {
  std::string dims, dtype, spacing;
  bool big_endian = false;
  void add_to(CLI::App& cmd);
  io::ReadOptions to_read_options() const;
};

std::string human_bytes(std::uint64_t bytes);
// "512M", "2G", "64k" or plain bytes (binary multiples); throws Error naming `option`.
std::uint64_t parse_byte_size(const std::string& text, const std::string& option);

}  // namespace strata::cli
