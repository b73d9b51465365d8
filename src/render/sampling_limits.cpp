#include "strata/render/sampling_limits.hpp"

#include <fmt/format.h>

#include "strata/core/error.hpp"

namespace strata::render {

void check_step(double step, const char* parameter) {
  if (!(step > 0)) throw ParameterError(parameter, fmt::format("must be positive, got {}", step));
  if (!(step >= kMinStep && step <= kMaxStep))
    throw ParameterError(parameter, fmt::format("must lie in [{}, {}] voxels (at most {} samples per voxel), got {}",
                                                kMinStep, kMaxStep, 1 / kMinStep, step));
}

}  // namespace strata::render
