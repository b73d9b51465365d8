#pragma once
// The flags of `strata compress`, shared with `strata-mpi compress` (apps/strata-mpi): the same
// names, defaults, checks and report.
#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "report.hpp"
#include "strata/ta/compress.hpp"

namespace strata::cli {

struct CompressArgs {
  std::string input, output, quant, memory_limit;  // quant empty: the library's default
  int brick = 32, overlap = 2, rank = 0, hooi = 1, zstd = 3;
  std::optional<double> psnr, rmse, max_error;
  double coarse_growth = 2.0;
  RawInputArgs raw;
  bool all_volumes = false;
  std::string codec{ta::kBrickedCodecName};
};

// Adds input, -o, the codec flags and the raw-input flags to `cmd` (not --all-volumes).
void add_compress_flags(CLI::App& cmd, CompressArgs& args);

// The parameters the flags ask for, checked by ta::validate; a bad value throws UsageError
// naming its flag.
ta::CompressParams to_params(const CompressArgs& args);

// The one-line summary (and the error-target and global-basis lines) on stdout.
void print_compress_report(const std::string& name, const ta::CompressParams& params, const ta::CompressReport& r);

}  // namespace strata::cli
