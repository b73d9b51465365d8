// strata.compress and strata.labels.encode: a numpy array or a volume file into a .strata file,
// with the CLI's defaults (`strata compress`, `strata labels encode`), through ta::compress_volume
// and mixture::encode_labels. Same parameters, same library calls, so the same bytes.
#include <optional>
#include <string>

#include <fmt/format.h>

#include "bindings.hpp"
#include "strata/core/error.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/quant/scheme.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/target_codec.hpp"

namespace strata::python {

namespace {

// Refuses writing over the input, which the writer's rename would replace while it is read.
void check_not_input(py::handle source, const std::filesystem::path& out) {
  if (py::isinstance<py::array>(source)) return;
  const std::filesystem::path in = path_from_python(source, "source");
  std::error_code ec;
  if (std::filesystem::equivalent(in, out, ec))
    throw py::value_error("out_path: " + out.string() + " is the input file");
}

// The three target arguments name at most one target; its rules are the library's.
ta::ErrorTarget error_target(std::optional<double> psnr, std::optional<double> rmse, std::optional<double> max_error,
                             double coarse_growth) {
  ta::ErrorTarget t;
  t.coarse_growth = coarse_growth;
  if (int(psnr.has_value()) + int(rmse.has_value()) + int(max_error.has_value()) > 1)
    throw py::value_error("psnr, rmse, max_error: give at most one error target");
  if (psnr) t = {ta::TargetKind::psnr, *psnr, coarse_growth};
  if (rmse) t = {ta::TargetKind::rmse, *rmse, coarse_growth};
  if (max_error) t = {ta::TargetKind::max_error, *max_error, coarse_growth};
  return t;
}

// The arguments as CompressParams, checked by ta::validate (its ParameterError reaches Python
// as strata.ParameterError, a ValueError naming the field).
ta::CompressParams compress_params(std::optional<int> rank, int brick, int overlap, std::optional<std::string> quant,
                                   std::optional<int> hooi, int zstd, const ta::ErrorTarget& target,
                                   const std::string& codec, std::optional<std::uint64_t> memory_limit) {
  ta::CompressParams p;
  p.layout = {brick, overlap};
  p.codec.target = target;
  p.codec.rank = rank ? *rank : ta::default_rank(p.layout, target.kind);
  if (quant) p.codec.quant = quant::QuantScheme::parse(*quant);
  if (hooi) p.codec.hooi_iterations = *hooi;
  p.codec.zstd_level = zstd;
  p.codec_name = codec;
  if (memory_limit) p.memory_limit = *memory_limit;
  ta::validate(p);
  return p;
}

// Runs `encode(input)` with the GIL released (the input is closed there too: a gzip input's
// temporary file is deleted), then raises what the progress callback raised, if anything.
template <class Encode>
auto run_encoder(std::unique_ptr<io::VolumeSource> input, PythonProgress& sink, Encode&& encode) {
  decltype(encode(*input)) report;
  {
    py::gil_scoped_release release;
    report = encode(*input);
    input.reset();
  }
  sink.rethrow();
  return report;
}

py::dict compress_report(const ta::CompressReport& r) {
  py::list levels;
  for (const ta::LevelCounts& l : r.levels) {
    py::dict d;
    d["bricks"] = l.bricks;
    d["constant"] = l.constant;
    d["hosvd_trials"] = l.hosvd_trials;
    d["rmse"] = l.rmse;
    d["max_error"] = l.max_error;
    levels.append(d);
  }
  py::dict d;
  d["levels"] = levels;
  d["file_bytes"] = r.file_bytes;
  d["core_bytes"] = r.core_bytes;
  d["factor_bytes"] = r.factor_bytes;
  d["brick_header_bytes"] = r.brick_header_bytes;
  d["container_bytes"] = r.container_bytes;
  d["input_voxels"] = r.input_voxels;
  d["bits_per_voxel"] = 8.0 * double(r.file_bytes) / double(std::max<std::uint64_t>(1, r.input_voxels));
  d["seconds"] = r.seconds;
  d["attempts"] = r.attempts;
  d["global_fit"] = r.global_fit;
  return d;
}

py::dict encode_report(const mixture::EncodeReport& r) {
  py::dict d;
  d["nodes"] = r.nodes;
  d["internal_nodes"] = r.internal_nodes;
  d["sources"] = r.sources;
  d["depth"] = r.depth;
  d["distinct_mixtures"] = r.distinct_mixtures;
  d["mip_levels"] = r.mip_levels;
  d["background_fraction"] = r.background_fraction;
  d["max_l1_error"] = r.max_l1 ? py::object(py::float_(*r.max_l1)) : py::object(py::none());
  d["file_bytes"] = r.file_bytes;
  d["graph_bytes"] = r.graph_bytes;
  d["ids_bytes"] = r.ids_bytes;
  d["normals_bytes"] = r.normals_bytes;
  d["bits_per_voxel"] = r.bits_per_voxel;
  d["seconds"] = r.seconds;
  return d;
}

}  // namespace

void register_compress(py::module_& m) {
  const ta::CompressParams defaults;
  m.def(
      "compress",
      [](py::handle source, py::handle out_path, std::optional<int> rank, int brick, int overlap,
         std::optional<std::string> quant, std::optional<int> hooi, int zstd, std::optional<double> psnr,
         std::optional<double> rmse, std::optional<double> max_error, double coarse_growth, const std::string& codec,
         std::optional<std::uint64_t> memory_limit, py::handle progress, py::handle spacing, py::handle shape,
         py::handle dtype, bool big_endian, std::optional<std::int64_t> volume) {
        const std::filesystem::path out = path_from_python(out_path, "out_path");
        const ta::CompressParams params =
            compress_params(rank, brick, overlap, quant, hooi, zstd, error_target(psnr, rmse, max_error, coarse_growth),
                            codec, memory_limit);
        check_not_input(source, out);
        PythonProgress sink(progress);
        return compress_report(run_encoder(open_source(source, shape, dtype, spacing, big_endian, volume), sink,
                                           [&](io::VolumeSource& input) {
                                             return ta::compress_volume(input, out, params, sink);
                                           }));
      },
      py::arg("source"), py::arg("out_path"), py::kw_only(), py::arg("rank") = py::none(),
      py::arg("brick") = defaults.layout.brick, py::arg("overlap") = defaults.layout.overlap,
      py::arg("quant") = py::none(), py::arg("hooi") = py::none(), py::arg("zstd") = defaults.codec.zstd_level,
      py::arg("psnr") = py::none(), py::arg("rmse") = py::none(), py::arg("max_error") = py::none(),
      py::arg("coarse_growth") = defaults.codec.target.coarse_growth, py::arg("codec") = defaults.codec_name,
      py::arg("memory_limit") = py::none(), py::arg("progress") = py::none(), py::arg("spacing") = py::none(),
      py::arg("shape") = py::none(), py::arg("dtype") = py::none(), py::arg("big_endian") = false,
      py::arg("volume") = py::none(),
      R"(Compresses a volume into a bricked tensor-approximation octree, as `strata compress` does.

source is a (z, y, x) numpy array (spacing=(sz, sy, sx), default 1) or a volume file (raw files
without a sidecar take shape, dtype, spacing and big_endian; volume=T picks one volume of a 4-D
file). Defaults are the CLI's: brick=32, overlap=2, rank=brick/2 (the cap brick with an error
target), quant="u16,b8log+", hooi=1, zstd=3, codec: the default bricked codec (strata.codecs() lists every codec). psnr, rmse or max_error code to
an error target instead of a fixed rank (quant and hooi must then stay unset). memory_limit bounds
the working memory in bytes. progress: True for a text bar, or a callable progress(task, done,
total). Returns a report dict (bricks per level, bytes, bits per voxel, seconds).)");

  m.def(
      "codecs",
      [] {
        py::list list;
        for (const ta::BrickCodec* c : ta::codecs()) {
          py::dict d;
          d["name"] = std::string(c->name());
          d["mode"] = std::string(ta::codec_mode_name(c->mode()));
          d["summary"] = std::string(c->summary());
          d["distributed"] = c->distributed();
          list.append(d);
        }
        return list;
      },
      "The brick codecs compress(codec=...) takes: a dict per codec entry (name, mode, summary, distributed).");

  py::module_ labels = m.def_submodule("labels", "Label (segmentation) volumes as Mixture Graphs");
  const mixture::EncodeOptions label_defaults;
  labels.def(
      "encode",
      [](py::handle source, py::handle out_path, int bits, const std::string& strategy, std::uint32_t tau,
         const std::string& ids, int zstd, bool measure_error, bool normals, py::handle progress, py::handle spacing,
         py::handle shape, py::handle dtype, bool big_endian, std::optional<std::int64_t> volume) {
        const std::filesystem::path out = path_from_python(out_path, "out_path");
        mixture::EncodeOptions o;
        o.bits = bits;
        o.strategy = mixture::parse_pair_score(strategy);
        o.tau = tau;
        o.ids = mixture::parse_ids_mode(ids);
        o.ids_zstd = zstd;
        o.measure_error = measure_error;
        o.normals = normals;
        mixture::validate(o);
        check_not_input(source, out);
        PythonProgress sink(progress);
        auto input = open_source(source, shape, dtype, spacing, big_endian, volume);
        if (!dtype_is_integer(input->info().dtype))
          throw py::type_error(fmt::format("{}: {} samples: a label volume needs integer samples (uint8, int8, uint16, "
                                           "int16, uint32 or int32)",
                                           input->path().string(), dtype_name(input->info().dtype)));
        return encode_report(run_encoder(std::move(input), sink, [&](io::VolumeSource& labels) {
          return mixture::encode_labels(labels, out, o, sink);
        }));
      },
      py::arg("source"), py::arg("out_path"), py::kw_only(), py::arg("bits") = label_defaults.bits,
      py::arg("strategy") = "max-reduction", py::arg("tau") = label_defaults.tau, py::arg("ids") = "blocks",
      py::arg("zstd") = label_defaults.ids_zstd, py::arg("measure_error") = label_defaults.measure_error,
      py::arg("normals") = label_defaults.normals, py::arg("progress") = py::none(), py::arg("spacing") = py::none(),
      py::arg("shape") = py::none(), py::arg("dtype") = py::none(), py::arg("big_endian") = false,
      py::arg("volume") = py::none(),
      R"(Encodes an integer label volume as a Mixture Graph, as `strata labels encode` does.

source is a (z, y, x) integer numpy array or a volume file (raw arguments as for compress).
Defaults are the CLI's: bits=9, strategy="max-reduction", tau=3, ids="blocks", zstd=9; normals=True
also stores the normals graph for lit rendering; measure_error=False skips measuring the max l1
error. Returns a report dict (nodes, depth, bytes, bits per voxel, seconds).)");
}

}  // namespace strata::python
