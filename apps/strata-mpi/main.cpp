// `strata-mpi compress IN -o OUT.strata [the flags of strata compress]` and
// `strata-mpi labels encode IN -o OUT.strata [the flags of strata labels encode]`, started by
// mpirun: distributed compression and label encoding (docs/distributed.md). The same flags,
// checks and report as `strata compress` and `strata labels encode` (apps/strata/
// compress_flags.hpp, labels_encode_flags.hpp), and the same files. Exit codes: 0 success,
// 1 runtime error, 2 usage error, agreed by all ranks; one rank prints the error.
#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <string>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "compress_flags.hpp"
#include "strata/ta/codec_registry.hpp"
#include "labels_encode_flags.hpp"
#include "error_exit.hpp"
#include "malloc_tuning.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/dist/compress.hpp"
#include "strata/dist/labels.hpp"
#include "strata/io/file_names.hpp"
#include "strata/ta/compress.hpp"

namespace {

using namespace strata;

// What to try after running out of memory, per command.
constexpr const char* kCompressMemoryHint = "use more ranks, a smaller --brick or fewer --threads";
constexpr const char* kLabelsMemoryHint =
    "rank 0 holds the coarser mip levels, the mixture table and the factorisation as one process would "
    "(docs/distributed.md, Limits); more ranks do not shrink them: use a node with more memory";

// Ranks that share this node (they share its cores).
int ranks_on_this_node() {
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int n = 1;
  MPI_Comm_size(node, &n);
  MPI_Comm_free(&node);
  return n;
}

// strata-mpi runs the codecs whose bricks depend on their own samples only, at a fixed rank
// (ta::BrickCodec::distributed; dist::compress_distributed says why).
void check_supported(const cli::CompressArgs& args) {
  const ta::BrickCodec* codec = ta::find_codec(args.codec, ta::CodecMode::fixed_rank);
  if (codec != nullptr && !codec->distributed())
    throw cli::UsageError("--codec", "strata-mpi does not write " + args.codec + " (it fits the whole volume before " +
                                         "its first brick); use `strata compress --codec " + args.codec + "`");
  for (const auto& [value, flag] : {std::pair{args.psnr, "--psnr"}, {args.rmse, "--rmse"}, {args.max_error, "--max-error"}})
    if (value)
      throw cli::UsageError(flag, "strata-mpi compresses at a fixed rank only (an error target's per-brick "
                                  "choices depend on every earlier row); use `strata compress`");
}

void print_distributed_report(const dist::DistributedReport& r) {
  std::uint64_t sent = 0;
  for (std::size_t k = 0; k < r.ranks.size(); ++k) {
    const dist::RankStats& s = r.ranks[k];
    sent += s.sent_bytes;
    std::printf("rank %zu: %lld level-0 brick rows, %lld bricks, read %s, sent %s, received %s of decoded slices, "
                "encoded %s; scan %.2f s, encode %.2f s, exchange %.2f s, write %.2f s\n",
                k, (long long)s.level0_rows, (long long)s.bricks, cli::human_bytes(s.input_bytes).c_str(),
                cli::human_bytes(s.sent_bytes).c_str(), cli::human_bytes(s.received_bytes).c_str(),
                cli::human_bytes(s.payload_bytes).c_str(), s.scan_seconds, s.encode_seconds, s.exchange_seconds,
                s.write_seconds);
  }
  std::printf("%zu ranks: %s of decoded slices exchanged\n", r.ranks.size(), cli::human_bytes(sent).c_str());
}

// strata-mpi labels encode cannot estimate the normals (they need the whole volume on one process).
void check_supported(const cli::LabelsEncodeArgs& args) {
  if (args.normals)
    throw cli::UsageError("--normals", "strata-mpi cannot store a normals graph (the normals are estimated over the "
                                       "whole volume on one process); use `strata labels encode --normals`");
}

void print_label_ranks(const dist::DistributedLabelsReport& r) {
  std::uint64_t sent = 0;
  for (std::size_t k = 0; k < r.ranks.size(); ++k) {
    const dist::LabelRankStats& s = r.ranks[k];
    if (k > 0) sent += s.part_bytes;
    std::printf("rank %zu: slices [%lld, %lld), read %s, part %s (%llu level-1 mixtures); values %.2f s, ids %.2f s, ",
                k, (long long)s.z_begin, (long long)s.z_end, cli::human_bytes(s.input_bytes).c_str(),
                cli::human_bytes(s.part_bytes).c_str(), (unsigned long long)s.part_mixtures, s.values_seconds,
                s.ids_seconds);
    if (k == 0) {
      std::printf("merge %.2f s, factorise and write %.2f s\n", s.merge_seconds, s.write_seconds);
    } else {
      std::printf("send %.2f s\n", s.merge_seconds);
    }
  }
  std::printf("%zu ranks: %s of parts sent to rank 0\n", r.ranks.size(), cli::human_bytes(sent).c_str());
}

// The per-rank lines of print_label_ranks() as JSON (--json).
nlohmann::json label_ranks_json(const dist::DistributedLabelsReport& r) {
  nlohmann::json ranks = nlohmann::json::array();
  for (const dist::LabelRankStats& s : r.ranks)
    ranks.push_back({{"z_begin", s.z_begin},
                     {"z_end", s.z_end},
                     {"input_bytes", s.input_bytes},
                     {"part_bytes", s.part_bytes},
                     {"part_mixtures", s.part_mixtures},
                     {"values_seconds", s.values_seconds},
                     {"ids_seconds", s.ids_seconds},
                     {"merge_seconds", s.merge_seconds},
                     {"write_seconds", s.write_seconds}});
  return ranks;
}

// Sets the worker threads of this rank: `threads`, or the node's hardware threads divided by
// the ranks on it.
void set_rank_threads(int threads) {
  if (threads > max_thread_count()) throw cli::UsageError("--threads", "at most " + std::to_string(max_thread_count()));
  set_thread_count(threads > 0 ? threads : std::max(1, hardware_threads() / ranks_on_this_node()));
}

// On every rank: the threads, the flags (`check`) and, on rank 0 alone (it writes the file),
// the output path; agreed, so all ranks go on or all stop.
template <class Check>
void check_setup(int rank, int threads, const std::string& input, const std::string& output, Check&& check) {
  dist::agree_on(MPI_COMM_WORLD, [&] {
    set_rank_threads(threads);
    check();
    if (rank == 0) cli::check_output_file(output, "--output", {input}, {io::kStrataExtension});
  });
}

void run_compress(const cli::CompressArgs& args, int rank, int threads) {
  ta::CompressParams params;
  check_setup(rank, threads, args.input, args.output, [&] {
    check_supported(args);
    params = cli::to_params(args);
  });
  const dist::DistributedReport report =
      dist::compress_distributed(MPI_COMM_WORLD, args.input, args.raw.to_read_options(), args.output, params);
  if (rank != 0) return;
  cli::print_compress_report(args.output, params, report.report);
  print_distributed_report(report);
}

void run_labels_encode(const cli::LabelsEncodeArgs& args, int rank, int threads, const std::string& progress_mode) {
  mixture::EncodeOptions options;
  check_setup(rank, threads, args.input, args.output, [&] {
    check_supported(args);
    options = cli::to_encode_options(args);
  });
  const std::unique_ptr<ProgressSink> progress =
      make_progress_sink(rank == 0 ? parse_progress_mode(progress_mode) : ProgressMode::silent);
  const dist::DistributedLabelsReport report = dist::encode_labels_distributed(
      MPI_COMM_WORLD, args.input, args.raw.to_read_options(), args.output, options, *progress);
  if (rank != 0) return;
  if (args.json) {
    nlohmann::json j = cli::encode_report_json(args.output, report.dims, options, args, report.report);
    j["ranks"] = label_ranks_json(report);
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  cli::print_encode_report(args.output, report.dims, options, args, report.report);
  print_label_ranks(report);
}

// Parses and runs; returns this rank's exit code. Every rank takes the same collective steps.
int run(int argc, char** argv, int rank) {
  const bool speaks = rank == 0;
  CLI::App app{"strata-mpi: distributed preprocessing over MPI (run under mpirun; docs/distributed.md)", "strata-mpi"};
  app.require_subcommand(1);
  int threads = 0;
  std::string progress_mode = "auto";
  app.add_option("--progress", progress_mode, "Progress display of rank 0 (labels encode): auto, bar, json, none")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "bar", "json", "none"}));
  app.add_option("--threads", threads,
                 "Worker threads per rank (default: the hardware threads of the node divided by its ranks)")
      ->check(cli::non_negative_integer<int>());
  auto compress_args = std::make_shared<cli::CompressArgs>();
  CLI::App* compress = app.add_subcommand(
      "compress", "Compress a volume into a bricked tensor-approximation octree (.strata) across the MPI ranks; the "
                  "file is byte-identical to `strata compress` with the same flags (fixed rank, " +
                      std::string(ta::kBrickedCodecName) + ")");
  cli::add_compress_flags(*compress, *compress_args);
  auto label_args = std::make_shared<cli::LabelsEncodeArgs>();
  CLI::App* labels = app.add_subcommand("labels", "Label (segmentation) volumes");
  labels->require_subcommand(1);
  CLI::App* encode = labels->add_subcommand(
      "encode", "Encode a label volume as a Mixture Graph (.strata) across the MPI ranks: each reads and encodes its "
                "slices, rank 0 merges the parts and factorises; the file equals `strata labels encode`'s");
  cli::add_labels_encode_flags(*encode, *label_args);
  cli::check_option_values(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return speaks ? app.exit(e) : 0;
  } catch (const CLI::ParseError& e) {
    if (speaks) std::fprintf(stderr, "error: %s\nRun with --help for more information.\n", e.what());
    return 2;
  }
  const char* memory_hint = encode->parsed() ? kLabelsMemoryHint : kCompressMemoryHint;
  try {
    if (encode->parsed()) {
      run_labels_encode(*label_args, rank, threads, progress_mode);
    } else {
      run_compress(*compress_args, rank, threads);
    }
    return 0;
  } catch (const dist::PeerFailure&) {
    return 1;  // the rank that failed reports
  } catch (const Error&) {
    return cli::print_error(app, memory_hint);  // agreed: every rank leaves the same step
  } catch (const std::filesystem::filesystem_error&) {
    return cli::print_error(app, memory_hint);
  } catch (...) {
    // Out of memory or a failure nobody expected, possibly outside an agreed step (an exchange
    // buffer): the other ranks may wait in a collective, so the run ends here.
    cli::print_error(app, memory_hint);
    MPI_Abort(MPI_COMM_WORLD, 1);
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  strata::cli::keep_brick_buffers_mapped();
  MPI_Init(&argc, &argv);
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  int code = run(argc, argv, rank);
  // The exit code all ranks agree on: usage (2) over runtime (1) over success.
  MPI_Allreduce(MPI_IN_PLACE, &code, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return code;
}
