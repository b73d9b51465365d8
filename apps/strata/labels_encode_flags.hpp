#pragma once
// The flags of `strata labels encode`, shared with `strata-mpi labels encode` (apps/strata-mpi):
// the same names, defaults, checks and report.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "report.hpp"
#include "strata/mixture/encoded_labels.hpp"

namespace strata::cli {

struct LabelsEncodeArgs {
  std::string input, output, strategy = "max-reduction", ids = "blocks";
  int bits = 9, zstd = 9;
  std::uint32_t tau = 3;
  bool no_error = false, json = false, normals = false;
  int normals_radius = 3, normals_diffusion = 0, normals_band = 1;
  std::string normals_dither = "on";
  std::string memory_limit;
  std::string names;  // --names: a table of segment names ("none": no sidecar either)
  RawInputArgs raw;
  bool all_volumes = false;
};

// Adds input, -o, the encoding flags and the raw-input flags to `cmd` (not --all-volumes).
void add_labels_encode_flags(CLI::App& cmd, LabelsEncodeArgs& args);

// The names table the run stores (--names, else the input's MRIcron sidecar); none for "none".
std::optional<std::filesystem::path> names_table(const LabelsEncodeArgs& args);

// The options the flags ask for; a bad value throws UsageError naming its flag.
mixture::EncodeOptions to_encode_options(const LabelsEncodeArgs& args);

// The report as `--json` prints it.
nlohmann::json encode_report_json(const std::string& name, const Extent& dims, const mixture::EncodeOptions& o,
                                  const LabelsEncodeArgs& args, const mixture::EncodeReport& r);

// The summary on stdout (JSON with --json).
void print_encode_report(const std::string& name, const Extent& dims, const mixture::EncodeOptions& o,
                         const LabelsEncodeArgs& args, const mixture::EncodeReport& r);

}  // namespace strata::cli
