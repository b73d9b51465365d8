// The chunked views of a dataset: every level of a .strata file served as a Neuroglancer
// precomputed volume (/precomputed/<name>/...) and as an OME-Zarr image (/zarr/<name>/...),
// each chunk decoded from the file's bricks when it is asked for, so Neuroglancer, zarr-python,
// napari and vizarr read a URL without a converted copy.
//
// | path                                      | answer                                            |
// | ----------------------------------------- | ------------------------------------------------- |
// | /precomputed/<name>/info                   | the info JSON (io::PrecomputedView)               |
// | /precomputed/<name>/<key>/<x0>-<x1>_...    | a chunk: raw (images) or compressed_segmentation  |
// | /zarr/<name>/.zgroup, .zattrs              | the group and its multiscales (io::OmeZarrView)   |
// | /zarr/<name>/<level>/.zarray, .zattrs      | a level's array ({} for its attributes)           |
// | /zarr/<name>/<level>/<z>/<y>/<x>           | a chunk, zero-padded, blosc-zstd                  |
//
// Scalar files serve each level decoded at the stored rank in the source's sample type (as
// `strata decompress -o x.ome.zarr` writes them); label files level 0's exact ids and the
// dominant label of coarser levels (mixture::LevelDecoder), as uint32 or uint64 segmentations
// for precomputed. Plain volume files have no levels and are not served here.
#include <fmt/format.h>

#include "server/api_detail.hpp"
#include "strata/core/error.hpp"
#include "strata/io/ome_zarr.hpp"
#include "strata/io/precomputed.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/store/volume_set.hpp"
#include "strata/ta/level_source.hpp"

namespace strata::server::detail {

struct ChunkViews {
  std::unique_ptr<ta::TaVolume> ta;  // scalar files: what the levels decode
  std::vector<std::unique_ptr<io::VolumeSource>> levels;
  std::string unavailable;  // why the dataset has no views (a plain file), else empty
  std::optional<io::OmeZarrView> zarr;
  std::string zarr_unavailable;
  std::optional<io::PrecomputedView> precomputed;
  std::string precomputed_unavailable;
  DType precomputed_dtype = DType::u8;  // segmentations widen to uint32 (uint64 for 64-bit ids)
};

namespace {

std::vector<VolumeInfo> level_infos(const ChunkViews& v, std::optional<DType> dtype = {}) {
  std::vector<VolumeInfo> infos;
  for (const auto& level : v.levels) {
    infos.push_back(level->info());
    if (dtype) infos.back().dtype = *dtype;
  }
  return infos;
}

std::shared_ptr<const ChunkViews> build_views(Dataset& d, const ApiOptions& options) {
  auto v = std::make_shared<ChunkViews>();
  switch (d.session->kind()) {
    case render::DatasetKind::plain:
      v->unavailable = fmt::format("dataset {} is a plain volume file, held whole: only .strata files have levels to serve",
                                   d.name);
      return v;
    case render::DatasetKind::scalar: {
      v->ta = std::make_unique<ta::TaVolume>(store::open_volume(d.path, options.volume));
      const DType dtype = v->ta->source_info().dtype;
      for (int l = 0; l < v->ta->geometry().level_count(); ++l)
        v->levels.push_back(std::make_unique<ta::LevelSource>(*v->ta, l, v->ta->rank(), dtype, d.path));
      v->precomputed_dtype = dtype;
      break;
    }
    case render::DatasetKind::labels: {
      const mixture::EncodedLabels& labels = d.session->labels();
      for (int l = 0; l < labels.level_count(); ++l) v->levels.push_back(std::make_unique<mixture::LevelDecoder>(labels, l));
      const DType ids = labels.label_map().dtype();
      v->precomputed_dtype = dtype_size(ids) == 8 ? DType::u64 : DType::u32;
      break;
    }
  }
  try {
    v->zarr.emplace(level_infos(*v), d.name);
  } catch (const Error& e) {
    v->zarr_unavailable = e.what();
  }
  try {
    v->precomputed.emplace(level_infos(*v, v->precomputed_dtype), d.name,
                           io::PrecomputedEncoding{.jpeg_quality = options.precomputed_jpeg_quality});
  } catch (const Error& e) {
    v->precomputed_unavailable = e.what();
  }
  return v;
}

HttpResponse chunk_response(std::vector<std::byte> bytes) {
  HttpResponse r;
  r.content_type = "application/octet-stream";
  r.body.assign(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  return r;
}

// A non-negative integer written the one canonical way (no sign, no leading zeros), or nothing.
std::optional<std::int64_t> chunk_number(std::string_view text) {
  const auto n = parse_integer(text);
  if (!n || *n < 0 || std::to_string(*n) != text) return std::nullopt;
  return n;
}

[[noreturn]] void no_such_file(const Dataset& d, std::string_view rest) {
  throw ApiError(404, "", fmt::format("dataset {} has no file {}", d.name, rest));
}

}  // namespace

const ChunkViews& Dataset::chunk_views(const ApiOptions& options) {
  std::call_once(views_once_, [&] { views_ = build_views(*this, options); });
  return *views_;
}

HttpResponse precomputed_file(Dataset& d, std::string_view rest, const ApiOptions& options) {
  const ChunkViews& v = d.chunk_views(options);
  if (!v.unavailable.empty()) throw ApiError(404, "", v.unavailable);
  if (!v.precomputed) throw ApiError(404, "", v.precomputed_unavailable);
  if (rest == "info") return json_response(v.precomputed->info());
  const std::size_t slash = rest.find('/');
  if (slash == std::string_view::npos) no_such_file(d, rest);
  const auto chunk = v.precomputed->chunk(rest.substr(0, slash), rest.substr(slash + 1));
  if (!chunk) no_such_file(d, rest);
  Volume samples = v.levels[chunk->level]->read_box(chunk->box);
  if (samples.dtype() != v.precomputed_dtype) samples = samples.converted(v.precomputed_dtype);
  return chunk_response(v.precomputed->encode(*chunk, samples));
}

HttpResponse zarr_file(Dataset& d, std::string_view rest, const ApiOptions& options) {
  const ChunkViews& v = d.chunk_views(options);
  if (!v.unavailable.empty()) throw ApiError(404, "", v.unavailable);
  if (!v.zarr) throw ApiError(404, "", v.zarr_unavailable);
  if (rest == ".zgroup") return json_response(v.zarr->group());
  if (rest == ".zattrs") return json_response(v.zarr->attributes());
  const std::size_t slash = rest.find('/');
  const auto level = chunk_number(rest.substr(0, slash));
  if (slash == std::string_view::npos || !level || std::uint64_t(*level) >= v.zarr->level_count()) no_such_file(d, rest);
  const std::string_view key = rest.substr(slash + 1);
  if (key == ".zarray") return json_response(v.zarr->array(std::size_t(*level)));
  if (key == ".zattrs") return json_response(nlohmann::json::object());
  std::array<std::int64_t, 3> zyx{};
  std::string_view left = key;
  for (std::size_t axis = 0; axis < 3; ++axis) {
    const std::size_t end = axis < 2 ? left.find('/') : left.size();
    const auto n = chunk_number(left.substr(0, end));
    if (!n || (axis < 2 && end == std::string_view::npos)) no_such_file(d, rest);
    zyx[axis] = *n;
    left = axis < 2 ? left.substr(end + 1) : std::string_view();
  }
  const auto box = v.zarr->chunk_box(std::size_t(*level), {zyx[2], zyx[1], zyx[0]});
  if (!box) no_such_file(d, rest);
  return chunk_response(v.zarr->encode(std::size_t(*level), v.levels[std::size_t(*level)]->read_box(*box)));
}

}  // namespace strata::server::detail
