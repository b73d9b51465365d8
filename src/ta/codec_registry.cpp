// The registry of brick codecs and the one check of compress parameters.
#include "strata/ta/codec_registry.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/core/text.hpp"
#include "ta/builtin_codecs.hpp"

namespace strata::ta {

namespace {

struct Registry {
  std::mutex mutex;
  std::vector<std::unique_ptr<BrickCodec>> entries;
};

void add(Registry& r, std::unique_ptr<BrickCodec> codec) {
  for (const auto& e : r.entries)
    if (e->name() == codec->name() && e->mode() == codec->mode())
      throw Error(fmt::format("register_codec: a {} codec named \"{}\" is registered already",
                              codec_mode_name(codec->mode()), codec->name()));
  r.entries.push_back(std::move(codec));
}

// The built-in codecs, one line each, registered on first use (the libraries are static
// archives: a registration in an object nothing references would be dropped by the linker).
Registry& registry() {
  static Registry r;
  static const bool built_in = [] {
    add(r, fixed_rank_bricked_codec());
    add(r, error_target_bricked_codec());
    add(r, global_codec());
    return true;
  }();
  (void)built_in;
  return r;
}

}  // namespace

std::string_view codec_mode_name(CodecMode mode) {
  switch (mode) {
    case CodecMode::fixed_rank: return "fixed-rank";
    case CodecMode::error_target: return "error-target";
  }
  return "?";
}

CodecMode mode_of(const CompressParams& params) {
  return params.codec.target.kind == TargetKind::none ? CodecMode::fixed_rank : CodecMode::error_target;
}

void register_codec(std::unique_ptr<BrickCodec> codec) {
  if (!codec) throw Error("register_codec: no codec");
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  add(r, std::move(codec));
}

std::vector<const BrickCodec*> codecs() {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  std::vector<const BrickCodec*> all;
  for (const auto& e : r.entries) all.push_back(e.get());
  return all;
}

std::vector<std::string> codec_names() {
  std::vector<std::string> names;
  for (const BrickCodec* c : codecs())
    if (std::find(names.begin(), names.end(), c->name()) == names.end()) names.emplace_back(c->name());
  return names;
}

const BrickCodec* find_codec(std::string_view name, CodecMode mode) {
  for (const BrickCodec* c : codecs())
    if (c->name() == name && c->mode() == mode) return c;
  return nullptr;
}

bool is_codec_name(std::string_view name) {
  for (const BrickCodec* c : codecs())
    if (c->name() == name) return true;
  return false;
}

std::string quoted_codec_names() {
  std::vector<std::string> quoted;
  for (const std::string& n : codec_names()) quoted.push_back("\"" + n + "\"");
  return joined_list(quoted, "or");
}

const BrickCodec& codec_for(const CompressParams& params) {
  const CodecMode mode = mode_of(params);
  if (const BrickCodec* codec = find_codec(params.codec_name, mode)) return *codec;
  if (!is_codec_name(params.codec_name))
    throw ParameterError("CompressParams::codec_name",
                         fmt::format("unknown codec \"{}\" (expected {})", params.codec_name, quoted_codec_names()));
  std::vector<std::string> others;
  for (const BrickCodec* c : codecs())
    if (c->mode() == mode) others.emplace_back(c->name());
  if (mode == CodecMode::error_target)
    throw ParameterError("CompressParams::codec_name",
                         fmt::format("the {} codec stores fixed-rank cores; error targets (--psnr, --rmse, --max-error) "
                                     "need {}",
                                     params.codec_name, joined_list(others, "or")));
  throw ParameterError("CompressParams::codec_name",
                       fmt::format("the {} codec codes to an error target only; give one (--psnr, --rmse or "
                                   "--max-error) or use {}",
                                   params.codec_name, joined_list(others, "or")));
}

void validate(const CompressParams& params) {
  params.layout.validate();
  const BrickCodec& codec = codec_for(params);
  const CodecParams& c = params.codec;
  if (c.rank < 1 || c.rank > params.layout.brick)
    throw ParameterError("CodecParams::rank", "must be between 1 and the brick width " +
                                                  std::to_string(params.layout.brick) + ", got " + std::to_string(c.rank));
  if (c.hooi_iterations < 0 || c.hooi_iterations > kMaxHooiIterations)
    throw ParameterError("CodecParams::hooi_iterations", fmt::format("must be 0..{} sweeps, got {}", kMaxHooiIterations,
                                                                      c.hooi_iterations));
  if (c.zstd_level < 0 || c.zstd_level > kMaxZstdLevel)
    throw ParameterError("CodecParams::zstd_level",
                         fmt::format("must be 0 (off) to {}, got {}", kMaxZstdLevel, c.zstd_level));
  if (!(std::isfinite(c.target.coarse_growth) && c.target.coarse_growth >= 1))
    throw ParameterError("ErrorTarget::coarse_growth",
                         fmt::format("must be a finite factor >= 1, got {:g}", c.target.coarse_growth));
  check_target(c.target);
  // The encoder works with squared errors: a smaller target underflows to 0.
  if (c.target.kind == TargetKind::rmse && c.target.value < kMinRmseTarget)
    throw ParameterError("ErrorTarget::value",
                         fmt::format("must be at least {:g} (below, its square is no longer a positive number), got {:g}",
                                     kMinRmseTarget, c.target.value));
  const CodecParams defaults;
  if (c.target.kind != TargetKind::none &&
      (c.quant.to_string() != defaults.quant.to_string() || c.hooi_iterations != defaults.hooi_iterations))
    throw ParameterError(c.quant.to_string() != defaults.quant.to_string() ? "CodecParams::quant"
                                                                           : "CodecParams::hooi_iterations",
                         "quant, hooi: an error target chooses each brick's precision and basis; leave them unset");
  codec.validate(params);
}

}  // namespace strata::ta
