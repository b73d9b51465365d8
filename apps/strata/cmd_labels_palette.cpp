// `strata labels palette IN.strata --colors colors.json -o palette.json`: propagates RGBA per
// label through the Mixture Graph (paper §3.4), giving the pre-filtered colour of every node.
#include <optional>
#include <array>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/files.hpp"
#include "report.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/palette.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::cli {

namespace {

struct LabelsPaletteArgs {
  std::string input, colors, output;
  std::optional<std::int64_t> volume;
};

std::array<float, 4> parse_rgba(const nlohmann::json& j, const std::string& file, const std::string& key) {
  if (!j.is_array() || j.size() != 4) throw FormatError(file, key, "expected [r, g, b, a]");
  std::array<float, 4> c{};
  for (std::size_t i = 0; i < 4; ++i) {
    if (!j[i].is_number()) throw FormatError(file, key, "expected four numbers");
    c[i] = j[i].get<float>();
    if (!std::isfinite(c[i])) throw FormatError(file, key, "expected four finite numbers (a value beyond float's range)");
  }
  return c;
}

void run_labels_palette(const LabelsPaletteArgs& args, const GlobalOptions&) {
  using clock = std::chrono::steady_clock;
  check_output_file(args.output, "--output", {args.input, args.colors}, {io::kJsonExtension});
  const mixture::EncodedLabels labels(store::open_volume(args.input, args.volume));
  nlohmann::json colors = io::read_json_file(args.colors, "json");
  if (!colors.is_object()) throw FormatError(args.colors, "json", "expected an object {\"<label>\": [r, g, b, a], ...}");
  std::array<float, 4> fallback{0, 0, 0, 0};
  if (colors.contains("default")) fallback = parse_rgba(colors["default"], args.colors, "default");
  const mixture::LabelMap& map = labels.label_map();
  std::vector<float> src(std::size_t(map.size()) * 4);
  for (std::uint32_t i = 0; i < map.size(); ++i) std::copy(fallback.begin(), fallback.end(), src.begin() + 4 * i);
  std::uint64_t assigned = 0, unknown = 0;
  for (const auto& [key, value] : colors.items()) {
    if (key == "default") continue;
    std::int64_t label = 0;
    try {
      std::size_t used = 0;
      label = std::stoll(key, &used);
      if (used != key.size()) throw std::invalid_argument(key);
    } catch (const std::exception&) {
      throw FormatError(args.colors, key, "keys must be label values (integers) or \"default\"");
    }
    const auto c = parse_rgba(value, args.colors, key);
    if (auto id = map.id_of(label)) {
      std::copy(c.begin(), c.end(), src.begin() + 4 * *id);
      ++assigned;
    } else {
      ++unknown;
    }
  }
  const auto t0 = clock::now();
  const std::vector<float> out = mixture::propagate_palette(labels.graph(), labels.schedule(), src, 4);
  const double seconds = std::chrono::duration<double>(clock::now() - t0).count();
  nlohmann::json j{{"nodes", labels.graph().node_count()},
                   {"sources", labels.graph().num_sources},
                   {"channels", 4},
                   {"depth", labels.schedule().depth},
                   {"propagate_seconds", seconds},
                   {"labels_assigned", assigned},
                   {"labels_unknown", unknown}};
  nlohmann::json rgba = nlohmann::json::array();
  for (std::size_t n = 0; n < out.size() / 4; ++n) rgba.push_back({out[4 * n], out[4 * n + 1], out[4 * n + 2], out[4 * n + 3]});
  j["rgba"] = std::move(rgba);
  write_json_file(args.output, j, -1);
  std::printf("%s: %llu nodes, depth %u, propagated in %.3f ms (%llu labels coloured, %llu unknown)\n", args.output.c_str(),
              (unsigned long long)labels.graph().node_count(), labels.schedule().depth, seconds * 1e3,
              (unsigned long long)assigned, (unsigned long long)unknown);
}

}  // namespace

void register_labels_palette(CLI::App& labels, const GlobalOptions& global) {
  auto args = std::make_shared<LabelsPaletteArgs>();
  CLI::App* cmd = labels.add_subcommand("palette", "Propagate per-label RGBA through the graph: one RGBA per node (JSON)");
  cmd->add_option("input", args->input, "Input .strata label file")->required();
  cmd->add_option("--colors", args->colors, "JSON {\"<label value>\": [r,g,b,a], ..., \"default\": [r,g,b,a]}")->required();
  cmd->add_option("-o,--output", args->output, "Output palette JSON")->required();
  add_volume_option(*cmd, args->volume);
  cmd->callback([args, &global] {
    naming_files({args->input, args->colors, args->output}, [&] { run_labels_palette(*args, global); });
  });
}

}  // namespace strata::cli
