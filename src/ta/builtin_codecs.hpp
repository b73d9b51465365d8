#pragma once
// The built-in brick codecs, each defined in its own file and registered by one line in
// codec_registry.cpp.
#include <memory>

#include "strata/ta/codec_registry.hpp"

namespace strata::ta {

// ta-bricked at a fixed rank (codec_ta_bricked.cpp): paper 1's quantized Tucker bricks.
std::unique_ptr<BrickCodec> fixed_rank_bricked_codec();
// ta-bricked to an error target (codec_ta_bricked.cpp): per-brick ranks, coded coefficients.
std::unique_ptr<BrickCodec> error_target_bricked_codec();
// ta-global (codec_ta_global.cpp): paper 2's global bases with a quantized core per brick.
std::unique_ptr<BrickCodec> global_codec();

}  // namespace strata::ta
