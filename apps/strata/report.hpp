#pragma once
// Small helpers shared by subcommands: raw-input flags and human-readable numbers.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include <optional>

#include "strata/core/text.hpp"
#include "strata/io/byte_source.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::cli {

// --dims/--dtype/--spacing/--big-endian for raw inputs without a JSON sidecar, --volume for
// files of several volumes, --dataset and --level for containers and multiscale files.
struct RawInputArgs {
  std::string dims, dtype, spacing;
  bool big_endian = false;
  std::optional<std::int64_t> volume;
  std::string dataset;
  std::optional<std::int64_t> level;
  void add_to(CLI::App& cmd);
  io::ReadOptions to_read_options() const;
};

// --volume (aliases --component, --time): which volume of a file that holds several, including
// a .strata volume set.
void add_volume_option(CLI::App& cmd, std::optional<std::int64_t>& volume);

using strata::human_bytes;  // strata/core/text.hpp
// What reading a remote (http/https) file cost: {"bytes_fetched", "requests", "retries",
// "cache_hits"}, the "transfer" member of --json/--stats reports; printed as one line.
nlohmann::json transfer_json(const io::TransferStats& stats);
void print_transfer(const nlohmann::json& transfer);
// Writes `j` (indented when `indent` >= 0) through a temporary file and a rename.
void write_json_file(const std::filesystem::path& path, const nlohmann::json& j, int indent = 2);
// "512M", "2G", "64k" or plain bytes (binary multiples); throws Error naming `option`.
std::uint64_t parse_byte_size(const std::string& text, const std::string& option);

}  // namespace strata::cli
