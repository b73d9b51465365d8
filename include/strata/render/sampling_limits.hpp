#pragma once
/// @file
/// @brief The sample distance limits shared by the scalar and the label ray caster. A ray
/// through a volume whose diagonal is D voxels takes at most D / kMinStep samples: 20 per voxel,
/// more than trilinear reconstruction and pre-integrated classification can show.

namespace strata::render {

inline constexpr double kMinStep = 0.05;  ///< voxels of the sampled level
inline constexpr double kMaxStep = 16;

/// @brief Throws ParameterError(parameter) unless kMinStep <= step <= kMaxStep.
void check_step(double step, const char* parameter);

}  // namespace strata::render
