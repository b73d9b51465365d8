#pragma once
/// @file
/// @brief The names of the built-in brick codecs (metadata "codec", `--codec`), each spelled
/// here once; the registry entries (ta/codec_registry.hpp) and messages use these. Free of any
/// other include, so code that must stay light (the HTTP server) can name them.

namespace strata::ta {

/// @brief The bricked Tucker codec of paper 1, at a fixed rank or to an error target.
inline constexpr const char* kBrickedCodecName = "ta-bricked";
/// @brief The global-basis codec of paper 2 (docs/format.md, "Codec ta-global").
inline constexpr const char* kGlobalCodecName = "ta-global";

}  // namespace strata::ta
