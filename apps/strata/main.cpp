// `strata`: the command line. Exit codes: 0 ok, 1 runtime error, 2 usage error.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "error_exit.hpp"
#include "malloc_tuning.hpp"
#include "strata/core/error.hpp"
#include "strata/core/isa.hpp"
#include "strata/core/threads.hpp"
#include "strata/io/signal_cleanup.hpp"

namespace {

// --isa limits every kernel (an unsupported level is reported as a ParameterError for --isa);
// without it STRATA_ISA is read here, so a bad value is reported before any work starts.
void apply_isa_option(const std::string& name) {
  using namespace strata;
  if (name.empty()) active_isa();
  else set_isa_limit(*parse_isa(name));  // CLI::IsMember admitted only known names
}

void apply_thread_option(int threads) {
  if (threads > strata::max_thread_count())
    throw strata::cli::UsageError(
        "--threads", "at most " + std::to_string(strata::max_thread_count()) + " (" +
                         std::to_string(strata::kMaxThreadsPerHardwareThread) + " x the " +
                         std::to_string(strata::hardware_threads()) + " hardware threads of this machine), got " +
                         std::to_string(threads));
  strata::set_thread_count(threads);
}

// What to change when a subcommand runs out of memory.
std::string memory_hint(const std::string& command) {
  if (command == "compress") return "give a smaller --memory-limit or --brick, or fewer --threads";
  if (command == "generate") return "give a smaller --size or --count";
  if (command == "render") return "give a smaller --size, --cache or --max-bricks, or render the .strata file instead";
  if (command == "serve") return "give a smaller --cache-mb or serve fewer or smaller volumes";
  if (command == "labels encode")
    return "the coarser mip levels, the table of distinct mixtures or the factorisation did not fit: set "
           "--memory-limit to the memory this machine can spare (the input slabs shrink to fit), or encode "
           "without --normals (which reads the whole volume)";
  if (command.starts_with("labels")) return "the label volume's histogram mipmap did not fit: use a smaller volume";
  return "use fewer --threads or a smaller input";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace strata;
  cli::keep_brick_buffers_mapped();
  // SIGINT, SIGTERM and SIGHUP remove the outputs in progress (`<name>.tmp`, volume set members)
  // before the process ends.
  io::install_signal_cleanup();
  CLI::App app{"Strata: compressed multiresolution volumes — store, explore and query.", "strata"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "strata 0.1.0");
  cli::GlobalOptions global;
  app.add_option("--threads", global.threads,
                 "Worker threads (default: all hardware threads; at most " +
                     std::to_string(kMaxThreadsPerHardwareThread) + " x the hardware threads, here " +
                     std::to_string(max_thread_count()) + ")")
      ->check(cli::non_negative_integer<int>());
  app.add_option("--progress", global.progress, "Progress display: auto (bar on a terminal), bar, json, none")
      ->check(CLI::IsMember({"auto", "bar", "json", "none"}));
  app.add_option("--isa", global.isa,
                 "Widest instruction set the kernels may use: generic, sse4.2, avx2, avx512 (default: STRATA_ISA, "
                 "else all this CPU has)")
      ->check(CLI::IsMember({"generic", "sse4.2", "sse42", "avx2", "avx512"}));
  app.parse_complete_callback([&] {
    apply_thread_option(global.threads);
    apply_isa_option(global.isa);
  });

  cli::register_info(app, global);
  cli::register_convert(app, global);
  cli::register_formats(app, global);
  cli::register_generate(app, global);
  cli::register_compare(app, global);
  cli::register_compress(app, global);
  cli::register_decompress(app, global);
  cli::register_eval(app, global);
  cli::register_labels(app, global);
  cli::register_render(app, global);
  cli::register_serve(app, global);
  cli::register_demo(app, global);
  cli::check_option_values(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "error: %s\nRun with --help for more information.\n", e.what());
    return 2;
  } catch (...) {
    return cli::print_error(app, memory_hint(cli::running_command_name(app)));
  }
  return 0;
}
