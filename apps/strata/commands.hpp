#pragma once
// Each subcommand lives in its own file and registers itself on the CLI11 app.
#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <string>

#include "strata/core/progress.hpp"

namespace strata::cli {

// Options shared by every subcommand (set before the subcommand's callback runs).
struct GlobalOptions {
  int threads = 0;                // 0 = hardware threads
  std::string progress = "auto";  // auto | bar | json | none
  std::string isa;                // empty = STRATA_ISA or the machine's widest
  std::unique_ptr<ProgressSink> make_progress() const { return make_progress_sink(parse_progress_mode(progress)); }
};

void register_info(CLI::App& app, const GlobalOptions& global);
void register_convert(CLI::App& app, const GlobalOptions& global);
void register_generate(CLI::App& app, const GlobalOptions& global);
void register_compare(CLI::App& app, const GlobalOptions& global);
void register_compress(CLI::App& app, const GlobalOptions& global);
void register_decompress(CLI::App& app, const GlobalOptions& global);
void register_eval(CLI::App& app, const GlobalOptions& global);
void register_labels(CLI::App& app, const GlobalOptions& global);
void register_demo(CLI::App& app, const GlobalOptions& global);
void register_render(CLI::App& app, const GlobalOptions& global);

}  // namespace strata::cli
