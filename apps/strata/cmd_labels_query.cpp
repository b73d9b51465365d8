// `strata labels query IN.strata --box x0,y0,z0:x1,y1,z1`: the histogram of labels inside an
// axis-aligned box (paper §3.6): per label the expected voxel count +- sigma, by footprint
// assembly over the mip levels (default: hybrid, a level-0 shell plus sampled interior) or,
// with --naive, by an exact scan of level 0.
#include <optional>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/core/error.hpp"
#include "strata/core/extent.hpp"
#include "strata/io/http_source.hpp"
#include "strata/mixture/box_query.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::cli {

void register_labels_query(CLI::App& labels, const GlobalOptions& global);

namespace {

struct LabelsQueryArgs {
  std::string input, box, method = "hybrid";
  bool naive = false, json = false;
  std::size_t top = 0;
  std::uint64_t max_samples = 4096;
  std::optional<std::int64_t> volume;
};

void run_labels_query(const LabelsQueryArgs& args, const GlobalOptions&) {
  using clock = std::chrono::steady_clock;
  const mixture::EncodedLabels labels(store::open_volume(args.input, args.volume));
  const Extent dims = labels.level_dims(0);
  const Box box = args.box.empty() ? Box::whole(dims) : parse_box(args.box);
  if (box.empty() || !Box::whole(dims).contains(box))
    throw Error("--box " + box.to_string() + ": expected a non-empty box inside the volume (0,0,0:" +
                std::to_string(dims.x) + "," + std::to_string(dims.y) + "," + std::to_string(dims.z) + ")");
  mixture::QueryOptions options;
  options.method = args.naive ? mixture::QueryMethod::naive : mixture::parse_query_method(args.method);
  options.max_samples = args.max_samples;

  const auto t0 = clock::now();
  const mixture::MixtureLookup& lookup = labels.lookup();
  const double lookup_seconds = std::chrono::duration<double>(clock::now() - t0).count();
  const mixture::BoxQuery query(labels, lookup, labels.graph().num_sources);
  const auto t1 = clock::now();
  const mixture::BoxHistogram h = query.run(box, options);
  const double query_seconds = std::chrono::duration<double>(clock::now() - t1).count();

  std::vector<mixture::BoxCount> rows = h.counts;  // ascending source id = ascending label value
  if (args.top > 0) {
    std::stable_sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.count > b.count; });
    if (rows.size() > args.top) rows.resize(args.top);
  }
  const mixture::LabelMap& map = labels.label_map();
  const double volume = double(box.voxel_count());

  if (args.json) {
    nlohmann::json out = {{"file", args.input},
                          {"box", box.to_string()},
                          {"voxels", box.voxel_count()},
                          {"method", std::string(mixture::query_method_name(options.method))},
                          {"fetches", h.fetches},
                          {"level0_voxels", h.level0_voxels},
                          {"samples", h.samples},
                          {"pieces", h.pieces},
                          {"distinct_nodes", h.distinct_nodes},
                          {"labels_found", h.counts.size()},
                          {"total", h.total()},
                          {"query_seconds", query_seconds},
                          {"lookup_seconds", lookup_seconds}};
    nlohmann::json list = nlohmann::json::array();
    for (const auto& r : rows)
      list.push_back({{"label", map.value(r.source)}, {"count", r.count}, {"sigma", r.sigma},
                      {"fraction", r.count / volume}});
    out["labels"] = std::move(list);
    if (const auto transfer = io::transfer_stats_of(args.input)) out["transfer"] = transfer_json(*transfer);
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf("box:     %s (%lld voxels)\n", box.to_string().c_str(), (long long)box.voxel_count());
  std::printf("method:  %s, %llu ids read (%llu level-0 voxels, %llu samples), %.3f ms (lookup %.3f ms)\n",
              std::string(mixture::query_method_name(options.method)).c_str(), (unsigned long long)h.fetches,
              (unsigned long long)h.level0_voxels, (unsigned long long)h.samples, query_seconds * 1e3,
              lookup_seconds * 1e3);
  std::printf("labels:  %zu%s, total %.6g voxels\n", h.counts.size(),
              args.top > 0 && rows.size() < h.counts.size() ? (" (showing top " + std::to_string(rows.size()) + ")").c_str() : "",
              h.total());
  std::printf("%14s %16s %12s %10s\n", "label", "count", "sigma", "fraction");
  for (const auto& r : rows)
    std::printf("%14lld %16.3f %12.3f %9.5f%%\n", (long long)map.value(r.source), r.count, r.sigma,
                100.0 * r.count / volume);
}

}  // namespace

void register_labels_query(CLI::App& labels, const GlobalOptions& global) {
  auto args = std::make_shared<LabelsQueryArgs>();
  CLI::App* cmd = labels.add_subcommand(
      "query", "Histogram of the labels inside a box: expected voxel count +- sigma per label (footprint assembly)");
  cmd->add_option("input", args->input, "Encoded label volume (.strata, from `strata labels encode`)")->required();
  cmd->add_option("--box", args->box, "Box x0,y0,z0:x1,y1,z1 (half-open, level-0 voxels; default: whole volume)");
  cmd->add_option("--method", args->method,
                  "hybrid (level-0 shell + sampled interior), footprint (one sample per cube), naive (exact scan) "
                  "or coarse (at most --max-samples cells of one level; partly covered cells widen sigma)")
      ->check(CLI::IsMember({"hybrid", "footprint", "naive", "coarse"}));
  cmd->add_option("--max-samples", args->max_samples, "coarse: cells sampled at most")
      ->capture_default_str()
      ->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 40));
  cmd->add_flag("--naive", args->naive, "Exact count by scanning level 0 (same as --method naive; uses --threads)");
  cmd->add_option("--top", args->top, "Only the N labels with the largest counts (default: all, by label value)")
      ->check(non_negative_integer<std::size_t>());
  cmd->add_flag("--json", args->json, "Print JSON");
  add_volume_option(*cmd, args->volume);
  cmd->callback([args, &global] { naming_files({args->input}, [&] { run_labels_query(*args, global); }); });
}

}  // namespace strata::cli
