// `strata labels calibrate IN.strata`: how far the sigmas of box queries can be trusted on this
// file. Random boxes (seeded) are answered by the chosen method and counted exactly; the share
// of (label, box) pairs whose error exceeds 1..6 sigma is printed (Gaussian: 31.7%, 4.6%,
// 0.27% outside 1, 2, 3 sigma).
#include <optional>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/query_calibration.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::cli {

void register_labels_calibrate(CLI::App& labels, const GlobalOptions& global);

namespace {

struct LabelsCalibrateArgs {
  std::string input, method = "hybrid";
  std::vector<std::int64_t> sizes{64, 128};
  int boxes = 30;
  std::uint64_t seed = 1;
  bool json = false;
  std::optional<std::int64_t> volume;
};

void run_labels_calibrate(const LabelsCalibrateArgs& args, const GlobalOptions&) {
  const mixture::EncodedLabels labels(store::open_volume(args.input, args.volume));
  const mixture::BoxQuery query(labels, labels.lookup(), labels.graph().num_sources);
  mixture::QueryOptions options;
  options.method = mixture::parse_query_method(args.method);
  const mixture::QueryCalibration c = mixture::calibrate(query, args.sizes, args.boxes, args.seed, options);
  const long long worst_label = c.pairs ? (long long)labels.label_map().value(c.worst_source) : 0;
  if (args.json) {
    nlohmann::json out = {{"file", args.input},
                          {"method", args.method},
                          {"sizes", args.sizes},
                          {"boxes", c.boxes},
                          {"pairs", c.pairs},
                          {"mean_abs_error", c.pairs ? c.abs_error_sum / double(c.pairs) : 0.0}};
    for (int k = 1; k <= 6; ++k) out["outside_" + std::to_string(k) + "_sigma"] = c.share_outside(k);
    out["worst"] = {{"z", std::isinf(c.worst_z) ? nlohmann::json("inf") : nlohmann::json(c.worst_z)},
                    {"box", c.worst_box.to_string()},
                    {"label", worst_label},
                    {"estimate", c.worst_estimate},
                    {"sigma", c.worst_sigma},
                    {"exact", c.worst_exact}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf("%s: %llu boxes (%s), %llu label/box pairs, mean |error| %.4g voxels\n", args.input.c_str(),
              (unsigned long long)c.boxes, args.method.c_str(), (unsigned long long)c.pairs,
              c.pairs ? c.abs_error_sum / double(c.pairs) : 0.0);
  std::printf("outside 1/2/3/6 sigma: %.2f%% / %.2f%% / %.3f%% / %.3f%%  (Gaussian: 31.7%% / 4.6%% / 0.27%% / 0)\n",
              100.0 * c.share_outside(1), 100.0 * c.share_outside(2), 100.0 * c.share_outside(3),
              100.0 * c.share_outside(6));
  if (c.worst_z > 0.0)
    std::printf("worst: %.2f sigma, label %lld in box %s: %.3f +- %.3f, exact %.0f\n", c.worst_z, worst_label,
                c.worst_box.to_string().c_str(), c.worst_estimate, c.worst_sigma, c.worst_exact);
}

}  // namespace

void register_labels_calibrate(CLI::App& labels, const GlobalOptions& global) {
  auto args = std::make_shared<LabelsCalibrateArgs>();
  CLI::App* cmd = labels.add_subcommand(
      "calibrate", "Checks the sigmas of box queries against exact counts over random boxes (share outside k sigma)");
  cmd->add_option("input", args->input, "Encoded label volume (.strata, from `strata labels encode`)")->required();
  cmd->add_option("--sizes", args->sizes, "Box edge lengths (clamped to the volume)")
      ->delimiter(',')
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--boxes", args->boxes, "Random boxes per size (each is also counted exactly)")->capture_default_str()->check(CLI::Range(1, 10000));
  cmd->add_option("--seed", args->seed, "Seed of the box positions")->capture_default_str()->check(non_negative_integer<std::uint64_t>());
  cmd->add_option("--method", args->method, "Estimating method: hybrid, footprint or coarse")
      ->capture_default_str()
      ->check(CLI::IsMember({"hybrid", "footprint", "coarse"}));
  cmd->add_flag("--json", args->json, "Print JSON");
  add_volume_option(*cmd, args->volume);
  cmd->callback([args, &global] { naming_files({args->input}, [&] { run_labels_calibrate(*args, global); }); });
}

}  // namespace strata::cli
