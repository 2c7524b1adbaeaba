// Arm action noise (spec 8.3): a commanded joint target is perturbed in task space, with a
// spread proportional to how far the command moves the TCP, and mapped back to the joints.
//
//   dq = q_cmd - q_now;  dx = J dq (J: the 6 x n TCP Jacobian at q_now);
//   sigma_p = action_scale_factor * |dx_pos|;  sigma_r = rotation_noise_scale * sigma_p;
//   n = 3 position draws ~ N(0, sigma_p) truncated to +-max_tcp_position_noise, then
//       3 rotation draws ~ N(0, sigma_r) truncated to +-max_tcp_rotation_noise;
//   q = clip(q_cmd + J^+ n, joint limits)   (J^+ n: minimum-norm least squares).
//
// The draws come from the episode's own Rng, so noise is reproducible per episode. The
// recorded actions stay un-noised.
#pragma once

#include "mlspaces/core/export.h"

#include <span>
#include <vector>

#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/config.h"

namespace mlspaces::datagen {

/// The noisy target; `jac` is 6 x n row-major ([linear; angular] rows), `lower`/`upper` the
/// joint limits (+-inf for unlimited joints). With noise disabled returns q_cmd clipped.
/// @throws std::invalid_argument for mismatched sizes.
MLSPACES_API std::vector<double> NoisyArmTarget(std::span<const double> q_cmd,
                                                std::span<const double> q_now,
                                                std::span<const double> jac,
                                                std::span<const double> lower,
                                                std::span<const double> upper,
                                                const ActionNoiseConfig& config, Rng& rng);

}  // namespace mlspaces::datagen
