// Library errors name the parameter (ParameterError::parameter); the command line names the
// flag that sets it. This file is the one place that maps one to the other.
#include <string_view>

#include "commands.hpp"

namespace strata::cli {

namespace {

struct ParameterFlag {
  std::string_view parameter, flag;
};

// Library parameter name -> the flag that sets it, in whichever subcommand has that flag.
constexpr ParameterFlag kParameterFlags[] = {
    {"ApiOptions::cache_bytes", "--cache-mb"},
    {"BrickLayout::brick", "--brick"},
    {"BrickLayout::overlap", "--overlap"},
    {"CodecParams::hooi_iterations", "--hooi"},
    {"CodecParams::quant", "--quant"},
    {"CodecParams::rank", "--rank"},
    {"CodecParams::zstd_level", "--zstd"},
    {"CompressParams::codec_name", "--codec"},
    {"CompressParams::memory_limit", "--memory-limit"},
    {"EncodeOptions::bits", "--bits"},
    {"EncodeOptions::ids_zstd", "--zstd"},
    {"EncodeOptions::memory_limit", "--memory-limit"},
    {"ErrorTarget::coarse_growth", "--coarse-growth"},
    {"CameraSpec::fov_deg", "--fov"},
    {"CameraSpec::height", "--size"},
    {"CameraSpec::width", "--size"},
    {"FrameSettings::feature_scale", "--feature-scale"},
    {"FrameSettings::lod", "--lod"},
    {"FrameSettings::lod_bias", "--lod-bias"},
    {"FrameSettings::rank", "--rank"},
    {"FrameSettings::step", "--step"},
    {"LabelRenderOptions::lod_bias", "--lod-bias"},
    {"LabelRenderOptions::step", "--step"},
    {"NormalOptions::band", "--normals-band"},
    {"NormalOptions::diffusion", "--normals-diffusion"},
    {"NormalOptions::radius", "--normals-radius"},
    {"OrbitParams::azimuth_deg", "--azimuth"},
    {"OrbitParams::distance", "--distance"},
    {"OrbitParams::elevation_deg", "--elevation"},
    {"Params::count", "--count"},
    {"Params::dims", "--size"},
    {"ReadOptions::raw_dims", "--dims"},
    {"ReadOptions::raw_dtype", "--dtype"},
    {"ReadOptions::volume", "--volume"},
    {"ReadOptions::dataset", "--dataset"},
    {"ReadOptions::level", "--level"},
    {"RenderOptions::step", "--step"},
    {"RenderOptions::background", "--background"},
    {"SessionOptions::background", "--background"},
    {"SessionOptions::cache_bytes", "--cache"},
    {"SessionOptions::max_bricks", "--max-bricks"},
    {"SessionOptions::target_fps", "--target-fps"},
    {"box", "--box"},
    {"isa", "--isa"},
    {"level", "--level"},
    {"volume", "--volume"},
    {"preset_or_path", "--tf"},
    {"rank", "--rank"},
    {"progress_mode", "--progress"},
};

// Whether `flag` is an option of the app or of one of the subcommands this run parsed.
bool running_command_has(const CLI::App& app, const std::string& flag) {
  for (const CLI::App* cmd : running_commands(app))
    if (cmd->get_option_no_throw(flag) != nullptr) return true;
  return false;
}

}  // namespace

std::vector<const CLI::App*> running_commands(const CLI::App& app) {
  std::vector<const CLI::App*> chain;
  for (const CLI::App* cmd = &app; cmd != nullptr;) {
    chain.push_back(cmd);
    const std::vector<CLI::App*> parsed = cmd->get_subcommands();
    cmd = parsed.empty() ? nullptr : parsed.front();
  }
  return chain;
}

std::string running_command_name(const CLI::App& app) {
  std::string name;
  for (const CLI::App* cmd : running_commands(app))
    if (cmd != &app) name += (name.empty() ? "" : " ") + cmd->get_name();
  return name.empty() ? "strata" : name;
}

std::string flag_for_parameter(std::string_view parameter) {
  for (const ParameterFlag& p : kParameterFlags)
    if (p.parameter == parameter) return std::string(p.flag);
  return std::string(parameter);
}

std::string cli_message(const ParameterError& e, const CLI::App& app) {
  for (const ParameterFlag& p : kParameterFlags) {
    if (p.parameter != e.parameter()) continue;
    const std::string flag(p.flag);
    if (running_command_has(app, flag)) return flag + ": " + e.problem();
  }
  return e.what();
}

}  // namespace strata::cli
