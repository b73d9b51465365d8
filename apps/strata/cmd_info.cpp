// `strata info FILE`: what a volume file holds, computed by streaming it slab by slab.
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <vector>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "report.hpp"
#include "strata/core/statistics.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/io/formats.hpp"
#include "strata/core/error.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/store/container.hpp"
#include "strata/store/geometry_json.hpp"
#include "strata/store/metadata_json.hpp"
#include "strata/store/volume_set.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::cli {

namespace {

struct InfoArgs {
  std::string file;
  bool json = false;
  RawInputArgs raw;
};

// "origin:  x y z unit (space)" and, when the axes are not the world's, the direction cosines:
// where the volume lies, as its file says (store/geometry_json.hpp's form).
void print_geometry(const nlohmann::json& g) {
  const auto& o = g["origin"];
  const std::string unit = g.value("unit", std::string());
  const std::string space = g.value("space", std::string("unspecified"));
  std::printf("origin:      %g %g %g%s%s (world space %s)\n", o[0].get<double>(), o[1].get<double>(),
              o[2].get<double>(), unit.empty() ? "" : " ", unit.c_str(), space.c_str());
  const auto& d = g["direction"];
  const std::vector<double> identity{1, 0, 0, 0, 1, 0, 0, 0, 1};
  if (d.get<std::vector<double>>() != identity)
    std::printf("direction:   i (%g %g %g), j (%g %g %g), k (%g %g %g)\n", d[0].get<double>(), d[3].get<double>(),
                d[6].get<double>(), d[1].get<double>(), d[4].get<double>(), d[7].get<double>(), d[2].get<double>(),
                d[5].get<double>(), d[8].get<double>());
}

nlohmann::json volume_report(const io::VolumeSource& source, const VolumeStatistics& st) {
  const VolumeInfo& info = source.info();
  nlohmann::json j;
  j["file"] = source.path().string();
  j["format"] = io::detect_format(source.path()).name;
  j["dims"] = {info.dims.x, info.dims.y, info.dims.z};
  j["dtype"] = std::string(dtype_name(info.dtype));
  j["spacing"] = {info.spacing.x, info.spacing.y, info.spacing.z};
  if (!info.geometry.is_default()) j["geometry"] = store::geometry_to_json(info.geometry);
  j["voxels"] = st.voxel_count;
  j["bytes"] = info.byte_size();
  j["min"] = st.min;
  j["max"] = st.max;
  j["mean"] = st.mean;
  j["stddev"] = st.stddev;
  j["histogram"] = st.histogram;
  if (st.finite_count() != st.voxel_count)
    j["non_finite"] = {{"nan", st.nan_count}, {"positive_infinity", st.positive_infinity_count},
                       {"negative_infinity", st.negative_infinity_count}};
  if (st.distinct_values) j["distinct_values"] = *st.distinct_values;
  if (dtype_is_integer(info.dtype)) j["background_fraction"] = st.zero_fraction;
  return j;
}

VolumeStatistics statistics_of(io::VolumeSource& source, ProgressSink& progress) {
  StatisticsAccumulator stats;
  io::for_each_slab(source, [&](const Volume& slab, std::int64_t) { stats.add(slab); }, progress, "info");
  return stats.result();
}

// Range, mean and non-finite voxels of every volume of a file that holds several (the time
// points of a series drift, a channel may be empty): what to pick with --volume.
nlohmann::json each_volume_summary(const std::string& file, io::ReadOptions options, std::int64_t count,
                                   ProgressSink& progress) {
  nlohmann::json each = nlohmann::json::array();
  for (std::int64_t t = 0; t < count; ++t) {
    options.volume = t;
    const auto source = io::open_volume(file, options);
    const VolumeStatistics st = statistics_of(*source, progress);
    each.push_back({{"volume", t},
                    {"min", st.min},
                    {"max", st.max},
                    {"mean", st.mean},
                    {"stddev", st.stddev},
                    {"non_finite", st.voxel_count - st.finite_count()}});
  }
  return each;
}

void print_each_volume(const nlohmann::json& each) {
  const auto number = [](const nlohmann::json& v) { return v.is_number() ? v.get<double>() : std::nan(""); };
  std::printf("each volume: %6s %12s %12s %12s %12s %10s\n", "T", "min", "max", "mean", "stddev", "non-finite");
  for (const auto& v : each)
    std::printf("             %6lld %12g %12g %12g %12g %10llu\n", v["volume"].get<long long>(), number(v["min"]),
                number(v["max"]), number(v["mean"]), number(v["stddev"]), v["non_finite"].get<unsigned long long>());
}

void print_volume_report(const nlohmann::json& j) {
  std::printf("file:        %s\n", j["file"].get<std::string>().c_str());
  std::printf("format:      %s\n", j["format"].get<std::string>().c_str());
  std::printf("dims:        %lld x %lld x %lld  (%llu voxels, %s)\n", j["dims"][0].get<long long>(),
              j["dims"][1].get<long long>(), j["dims"][2].get<long long>(), j["voxels"].get<unsigned long long>(),
              human_bytes(j["bytes"].get<std::uint64_t>()).c_str());
  if (j.contains("volumes"))
    std::printf("volumes:     %lld of these dims; the statistics below are of volume %lld (--volume T picks another)\n",
                j["volumes"]["count"].get<long long>(), j["volumes"]["described"].get<long long>());
  std::printf("dtype:       %s\n", j["dtype"].get<std::string>().c_str());
  std::printf("spacing:     %g %g %g\n", j["spacing"][0].get<double>(), j["spacing"][1].get<double>(),
              j["spacing"][2].get<double>());
  if (j.contains("geometry")) print_geometry(j["geometry"]);
  // JSON has no NaN: a volume without finite values has null statistics.
  const auto number = [](const nlohmann::json& v) { return v.is_number() ? v.get<double>() : std::nan(""); };
  const bool non_finite = j.contains("non_finite");
  if (non_finite)
    std::printf("non-finite:  %llu NaN, %llu +inf, %llu -inf (the statistics below are of the other voxels)\n",
                j["non_finite"]["nan"].get<unsigned long long>(), j["non_finite"]["positive_infinity"].get<unsigned long long>(),
                j["non_finite"]["negative_infinity"].get<unsigned long long>());
  std::printf("range:       [%g, %g]\n", number(j["min"]), number(j["max"]));
  std::printf("mean:        %g (stddev %g)\n", number(j["mean"]), number(j["stddev"]));
  std::printf("histogram:   16 bins over the range:");
  for (auto& c : j["histogram"]) std::printf(" %llu", c.get<unsigned long long>());
  std::printf("\n");
  if (j.contains("distinct_values"))
    std::printf("distinct:    %llu values\n", j["distinct_values"].get<unsigned long long>());
  if (j.contains("background_fraction"))
    std::printf("background:  %.4f of voxels are 0\n", j["background_fraction"].get<double>());
  if (j.contains("volumes") && j["volumes"].contains("each")) print_each_volume(j["volumes"]["each"]);
}

// Opens a container (from `open`, which gives a fresh reader of the same bytes each call) with
// the reader of its codec, which checks every field docs/format.md defines (against each other
// and against the index), so the report below only describes valid files. Returns the container
// to report on.
using OpenContainer = std::function<std::unique_ptr<store::ContainerReader>()>;
std::unique_ptr<store::ContainerReader> open_validated(const OpenContainer& open, std::unique_ptr<ta::TaVolume>& volume) {
  auto reader = open();
  const std::string file = reader->name();
  const nlohmann::json& m = reader->metadata();
  const auto codec = m.find("codec");
  const std::string expected = ta::quoted_codec_names() + " or \"" + mixture::kMixtureCodecName + "\"";
  if (codec == m.end()) throw FormatError(file, "metadata.codec", "missing (expected " + expected + ")");
  if (codec->is_string() && ta::is_codec_name(codec->get_ref<const std::string&>())) {
    volume = std::make_unique<ta::TaVolume>(std::move(reader));
    return nullptr;
  }
  if (*codec == mixture::kMixtureCodecName) {
    mixture::EncodedLabels labels(open());  // its checks; the report reads `reader`
    return reader;
  }
  throw FormatError(file, "metadata.codec", "expected " + expected + ", got " + store::json_excerpt(*codec));
}

// A .strata file: container header, codec parameters, levels and brick counts, sizes.
nlohmann::json container_report(const OpenContainer& open) {
  std::unique_ptr<ta::TaVolume> volume;
  const std::unique_ptr<store::ContainerReader> labels = open_validated(open, volume);
  const store::ContainerReader& reader = volume ? volume->container() : *labels;
  const nlohmann::json& m = reader.metadata();
  nlohmann::json j{{"file", reader.name()}, {"format", "strata"}, {"file_bytes", reader.file_size()},
                   {"metadata_bytes", reader.metadata_bytes()}, {"index_bytes", reader.index_bytes()}};
  for (const char* key : {"codec", "source", "brick", "overlap", "rank", "quant", "hooi_iterations", "zstd_level", "global"})
    if (m.contains(key)) j[key] = m[key];
  std::vector<nlohmann::json> levels;
  if (m.contains("levels") && m["levels"].is_array())
    for (const auto& l : m["levels"]) levels.push_back({{"dims", l.value("dims", nlohmann::json())}, {"bricks", 0}, {"constant", 0}, {"payload_bytes", 0}});
  std::map<std::string, std::uint64_t> kinds;
  for (const auto& e : reader.bricks()) {
    ++kinds[store::payload_kind_name(e.kind)];
    if (e.key.level >= levels.size()) levels.resize(e.key.level + 1u, {{"bricks", 0}, {"constant", 0}, {"payload_bytes", 0}});
    auto& l = levels[e.key.level];
    l["bricks"] = l["bricks"].get<std::uint64_t>() + 1;
    l["constant"] = l["constant"].get<std::uint64_t>() + (e.kind == store::PayloadKind::constant);
    l["payload_bytes"] = l["payload_bytes"].get<std::uint64_t>() + e.size;
  }
  j["levels"] = levels;
  j["payload_kinds"] = kinds;
  j["sections"] = m.value("sections", nlohmann::json::object());
  if (m.value("codec", std::string()) == mixture::kMixtureCodecName) {  // label volume (strata labels encode)
    nlohmann::json g = m.value("stats", nlohmann::json::object());
    for (const char* key : {"ids", "bits", "bins", "strategy", "tau", "fractional"})
      if (m.contains(key)) g[key] = m[key];
    nlohmann::json ids = nlohmann::json::array();
    if (m.contains("levels") && m["levels"].is_array())
      for (const auto& l : m["levels"]) ids.push_back(l.value("ids_bytes", std::uint64_t(0)));
    g["ids_bytes"] = ids;
    if (m.contains("normals") && m["sections"].contains("normals")) {
      g["normals"] = m["normals"];
      g["normals"]["bytes"] = m["sections"]["normals"].value("size", std::uint64_t(0));
    }
    if (m.contains("label_names") && m["label_names"].is_object()) g["label_names"] = m["label_names"].size();
    j["mixture_graph"] = g;
  }
  if (m.contains("source") && m["source"].contains("dims")) {
    const auto& d = m["source"]["dims"];
    const double voxels = d[0].get<double>() * d[1].get<double>() * d[2].get<double>();
    j["bits_per_voxel"] = 8.0 * double(reader.file_size()) / voxels;
  }
  return j;
}

void print_container_report(const nlohmann::json& j) {
  std::printf("file:        %s (%s)\n", j["file"].get<std::string>().c_str(), human_bytes(j["file_bytes"].get<std::uint64_t>()).c_str());
  std::printf("format:      .strata (metadata %s, index %s)\n", human_bytes(j["metadata_bytes"].get<std::uint64_t>()).c_str(),
              human_bytes(j["index_bytes"].get<std::uint64_t>()).c_str());
  if (j.contains("codec")) std::printf("codec:       %s\n", j["codec"].get<std::string>().c_str());
  if (j.contains("source")) {
    const auto& s = j["source"];
    std::printf("source:      %s %s, spacing %s, value range %s\n", s.value("dims", nlohmann::json()).dump().c_str(),
                s.value("dtype", std::string("?")).c_str(), s.value("spacing", nlohmann::json()).dump().c_str(),
                s.value("value_range", nlohmann::json()).dump().c_str());
    if (s.contains("geometry")) print_geometry(s["geometry"]);
  }
  if (j.contains("brick"))
    std::printf("bricks:      width %d, overlap %d, rank %d, quant %s, zstd %d\n", j["brick"].get<int>(), j["overlap"].get<int>(),
                j.value("rank", 0), j.value("quant", std::string("?")).c_str(), j.value("zstd_level", 0));
  if (j.contains("global"))
    std::printf("global:      bases of ranks %s (fit %.5f), feature-scale ranks %s\n", j["global"].value("ranks", nlohmann::json()).dump().c_str(),
                j["global"].value("fit", 0.0), j["global"].value("ladder", nlohmann::json()).dump().c_str());
  if (j.contains("bits_per_voxel")) std::printf("size:        %.3f bits per source voxel\n", j["bits_per_voxel"].get<double>());
  if (j.contains("mixture_graph")) {  // label volume: graph statistics instead of bricks
    const auto& g = j["mixture_graph"];
    std::printf("graph:       %llu nodes (%llu sources, %llu internal), depth %u\n",
                g.value("nodes", 0ull), g.value("sources", 0ull), g.value("internal_nodes", 0ull), g.value("depth", 0u));
    std::printf("encoding:    %s, %d weight bits (%s bins), tau %u, ids %s\n", g.value("strategy", std::string("?")).c_str(),
                g.value("bits", 0), g.value("bins", std::string("?")).c_str(), g.value("tau", 0u),
                g.value("ids", std::string("?")).c_str());
    std::printf("mixtures:    %llu distinct, %llu input pairs\n", g.value("distinct_mixtures", 0ull), g.value("input_pairs", 0ull));
    if (g.contains("max_l1_error")) std::printf("error:       max l1 %.6f\n", g["max_l1_error"].get<double>());
    if (g.contains("label_names")) std::printf("names:       %zu segment names\n", g["label_names"].get<std::size_t>());
    if (g.contains("normals"))
      std::printf("normals:     a normals graph of %s (window radius %d, band %d, dithered: %s) for pre-filtered lighting\n",
                  human_bytes(g["normals"].value("bytes", std::uint64_t(0))).c_str(), g["normals"].value("radius", 0),
                  g["normals"].value("band", 0), g["normals"].value("error_diffusion", false) ? "yes" : "no");
    for (std::size_t l = 0; l < j["levels"].size() && l < g["ids_bytes"].size(); ++l)
      std::printf("level %zu:     %s, ids %s\n", l, j["levels"][l].value("dims", nlohmann::json()).dump().c_str(),
                  human_bytes(g["ids_bytes"][l].get<std::uint64_t>()).c_str());
    return;
  }
  for (std::size_t l = 0; l < j["levels"].size(); ++l) {
    const auto& lv = j["levels"][l];
    std::printf("level %zu:     %s, %llu bricks (%llu constant), %s\n", l, lv.value("dims", nlohmann::json()).dump().c_str(),
                lv["bricks"].get<unsigned long long>(), lv["constant"].get<unsigned long long>(),
                human_bytes(lv["payload_bytes"].get<std::uint64_t>()).c_str());
  }
  for (const auto& [kind, count] : j["payload_kinds"].items())
    std::printf("payloads:    %s x %llu\n", kind.c_str(), count.get<unsigned long long>());
}

// A volume set without --volume: the set's own size, then every member as a file of its own.
nlohmann::json volume_set_report(const store::ContainerReader& set) {
  const std::int64_t count = store::volume_count(set);
  nlohmann::json members = nlohmann::json::array();
  for (std::int64_t i = 0; i < count; ++i)
    members.push_back(container_report([&] { return store::open_member(set, i); }));
  return {{"file", set.name()},     {"format", "strata"},
          {"codec", store::kVolumeSetCodec}, {"file_bytes", set.file_size()},
          {"source", set.metadata().value("source", nlohmann::json::object())}, {"volumes", members}};
}

void print_volume_set_report(const nlohmann::json& j) {
  std::printf("file:        %s (%s)\n", j["file"].get<std::string>().c_str(), human_bytes(j["file_bytes"].get<std::uint64_t>()).c_str());
  std::printf("format:      .strata volume set of %zu volumes (--volume T opens one)\n", j["volumes"].size());
  for (const auto& member : j["volumes"]) {
    std::printf("\n");
    print_container_report(member);
  }
}

void run_strata_info(const InfoArgs& args) {
  const store::ContainerReader outer(args.file);
  nlohmann::json report;
  if (store::is_volume_set(outer) && !args.raw.volume) report = volume_set_report(outer);
  else report = container_report([&] { return store::open_volume(args.file, args.raw.volume); });
  if (outer.source().remote()) report["transfer"] = transfer_json(outer.source().transfer_stats());
  if (args.json) std::printf("%s\n", report.dump(2).c_str());
  else if (report.contains("volumes")) print_volume_set_report(report);
  else print_container_report(report);
  if (!args.json && report.contains("transfer")) print_transfer(report["transfer"]);
}

void run_info(const InfoArgs& args, const GlobalOptions& global) {
  if (store::is_strata_file(args.file)) {
    run_strata_info(args);
    return;
  }
  auto progress = global.make_progress();
  io::ReadOptions options = args.raw.to_read_options();
  options.progress = progress.get();
  // A file of several volumes is described by its first unless --volume names another; without
  // --volume every volume also gets a line of its own.
  const bool every_volume = !options.volume;
  if (!options.volume) options.volume = 0;
  auto source = io::open_volume(args.file, options);
  nlohmann::json report = volume_report(*source, statistics_of(*source, *progress));
  const std::int64_t count = source->info().volumes;
  if (count > 1) {
    report["volumes"] = {{"count", count}, {"described", *options.volume}};
    if (every_volume) report["volumes"]["each"] = each_volume_summary(args.file, options, count, *progress);
  }
  if (args.json) std::printf("%s\n", report.dump(2).c_str());
  else print_volume_report(report);
}

}  // namespace

void register_info(CLI::App& app, const GlobalOptions& global) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = app.add_subcommand("info", "Describe a volume (dims, dtype, spacing, range, histogram, labels) or a .strata file");
  cmd->add_option("file", args->file, "Volume file (raw, .nrrd/.nhdr, .nii/.nii.gz, .tif or a folder of slices)")
      ->required();
  cmd->add_flag("--json", args->json, "Print the report as JSON");
  args->raw.add_to(*cmd);
  cmd->callback([args, &global] { run_info(*args, global); });
}

}  // namespace strata::cli
