// `strata`: the command line. Exit codes: 0 ok, 1 runtime error, 2 usage error.
#include <cstdio>
#include <exception>
#include <string>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "commands.hpp"
#include "strata/core/error.hpp"
#include "strata/core/isa.hpp"
#include "strata/core/threads.hpp"

namespace {

// --isa limits every kernel (an unsupported level is reported as a ParameterError for --isa);
// without it STRATA_ISA is read here, so a bad value is reported before any work starts.
void apply_isa_option(const std::string& name) {
  using namespace strata;
  if (name.empty()) active_isa();
  else set_isa_limit(*parse_isa(name));  // CLI::IsMember admitted only known names
}

// The codecs allocate and free brick-sized buffers (B^3 floats = 128 KiB at B = 32, glibc's
// default mmap threshold) on every worker thread for every brick. With glibc's defaults those
// come from fresh mappings or from arena memory just returned to the kernel, and each brick pays
// its page faults again: on a 35 Mvoxel MRI the error-target encoder took 76 k page faults and
// 4.9 s of CPU, against 16.5 k and 3.7 s with the thresholds below (perf stat, same output).
// Large buffers (volumes, slabs) are still mapped and returned.
void keep_brick_buffers_mapped() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  using namespace strata;
  keep_brick_buffers_mapped();
  CLI::App app{"Strata: compressed multiresolution volumes — store, explore and query.", "strata"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "strata 0.1.0");
  cli::GlobalOptions global;
  app.add_option("--threads", global.threads, "Worker threads (default: all hardware threads)")->check(CLI::NonNegativeNumber);
  app.add_option("--progress", global.progress, "Progress display: auto (bar on a terminal), bar, json, none")
      ->check(CLI::IsMember({"auto", "bar", "json", "none"}));
  app.add_option("--isa", global.isa,
                 "Widest instruction set the kernels may use: generic, sse4.2, avx2, avx512 (default: STRATA_ISA, "
                 "else all this CPU has)")
      ->check(CLI::IsMember({"generic", "sse4.2", "sse42", "avx2", "avx512"}));
  app.parse_complete_callback([&] {
    set_thread_count(global.threads);
    apply_isa_option(global.isa);
  });

  cli::register_info(app, global);
  cli::register_convert(app, global);
  cli::register_generate(app, global);
  cli::register_compare(app, global);
  cli::register_compress(app, global);
  cli::register_decompress(app, global);
  cli::register_eval(app, global);
  cli::register_labels(app, global);
  cli::register_render(app, global);
  cli::register_serve(app, global);
  cli::register_demo(app, global);

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  } catch (const ParameterError& e) {
    std::fprintf(stderr, "error: %s\n", cli::cli_message(e, app).c_str());
    return 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
