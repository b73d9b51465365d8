#pragma once
// Checks a subcommand makes before any work starts: flag values it can never accept (a usage
// error, exit 2) and its outputs (never one of its inputs, the extension of what it writes, a
// place it can write to), plus the set of outputs a run removes again when it fails.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <functional>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/signal_cleanup.hpp"

namespace strata::cli {

// A value a flag can never take: main prints `error: <flag>: <problem>` and exits with 2 (a
// value only the input data rejects stays an Error, exit 1). parameter() is the flag, or a
// library parameter that cli_message maps to one.
class UsageError : public ParameterError {
 public:
  using ParameterError::ParameterError;
};

// The flag that sets a library parameter ("CodecParams::rank" -> "--rank"; parameter_flags.cpp),
// or the parameter itself when no flag does.
std::string flag_for_parameter(std::string_view parameter);

// Runs `check`; a ParameterError it throws (a library validation of the flags' values) is
// rethrown as a UsageError with the same parameter and problem.
void as_usage_error(const std::function<void()>& check);

// Runs `run`; an Error it throws (not a ParameterError) whose message names none of `files` and
// no flag is rethrown as "<files[0]>: <message>", so the user learns which file it is about.
void naming_files(const std::vector<std::string>& files, const std::function<void()>& run);

// The one check of every option of `app` and of its subcommands (all, recursively) that takes a
// value, before the option's own checks: an empty value is refused ("--psnr ''"), which CLI11
// would read as "not given" (an optional) or as 0 and go on ("--psnr=" CLI11 refuses itself);
// an integer option takes decimal digits only (CLI11 would read "010" as octal 8), a number
// option a number. The usage error names the flag and what it expects. Call once every option
// is added.
void check_option_values(CLI::App& app);

// --rank of decompress, eval and render, for a file that stores rank `stored` (0: none): the
// library's one rule (ta::reconstruction_rank; 0 = the stored rank). A negative rank is a usage
// error (exit 2), one the file does not store an error naming the file (exit 1).
int check_rank_flag(int requested, int stored, const std::string& file);

// Throws UsageError(flag) unless `value` is finite and lies in [lo, hi].
void check_finite_range(double value, double lo, double hi, const std::string& flag, std::string_view unit = "");

// Every output check below first refuses an output that would overwrite or change what an input
// reads (UsageError naming the output, the input and how they meet; io::overwrite_conflict): what
// each of `inputs` (empty entries skipped) reads is io::files_read (the path, the data files its
// header names, its sidecar, a folder with everything in it); they are compared by identity, so
// another spelling, a symlink or a hard link is the same file, and an output inside an input
// folder is refused as well. This one checks plain files the run writes as `<name>.tmp` renamed
// into place (render frames, volume set members), each with its temporary.
void check_spares_inputs(const std::vector<std::filesystem::path>& outputs, const std::string& flag,
                         const std::vector<std::string>& inputs);

// The checks of one output file before any work:
//  - it spares every input (above: check_spares_inputs);
//  - its name ends with one of `extensions` (case-insensitive; none = any name) (UsageError);
//  - it is not a directory and its directory exists and is writable (Error naming the flag).
void check_output_file(const std::string& output, const std::string& flag, const std::vector<std::string>& inputs,
                       std::initializer_list<std::string_view> extensions);
// check_output_file for a volume file io writes, with everything its writer adds beside it
// (io::files_written as `write` writes: a `.nhdr` name's `.raw` or `.raw.gz` data file, a raw
// file's sidecar, a folder format's staging folder): the format comes from the name (UsageError
// when unknown, listing the registered extensions), must have a writer and must be able to hold
// `dtype` samples when given.
const io::VolumeFormat& check_volume_output(const std::string& output, const std::string& flag,
                                            const std::vector<std::string>& inputs, const DType* dtype = nullptr,
                                            const io::WriteOptions& write = {});
// An output folder (created when missing) that files are added to: not one of the inputs, not
// inside an input folder, not an existing file, its parent writable (the files themselves:
// check_spares_inputs).
void check_output_folder(const std::string& output, const std::string& flag, const std::vector<std::string>& inputs);
// Refuses two outputs of one run that are the same file (the second would overwrite the first).
void check_distinct_outputs(const std::string& a, const std::string& flag_a, const std::string& b,
                            const std::string& flag_b);

// Outputs of a run that writes several files: each is added once written; unless commit() is
// called, the destructor removes them again (and the folder, when this run created it and it is
// empty), so a failed run leaves no output behind; until then a stop signal removes them too
// (io::RemovedOnSignal; the folder this run created with everything in it).
class OutputSet {
 public:
  OutputSet() = default;
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;
  void created_folder(const std::filesystem::path& folder) {
    folder_ = folder;
    on_signal_.emplace_back(folder);
  }
  // Call once the file is written (while it is written, AtomicOutputFile covers its temporary).
  void add(const std::filesystem::path& written) {
    written_.push_back(written);
    on_signal_.emplace_back(written);
  }
  void commit() {
    committed_ = true;
    on_signal_.clear();
  }

 private:
  std::vector<std::filesystem::path> written_;
  std::filesystem::path folder_;
  std::vector<io::RemovedOnSignal> on_signal_;  // destroyed after ~OutputSet removed the files
  bool committed_ = false;
};

}  // namespace strata::cli
