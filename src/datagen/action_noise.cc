#include "mlspaces/datagen/action_noise.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "mlspaces/robots/ik.h"

namespace mlspaces::datagen {

std::vector<double> NoisyArmTarget(std::span<const double> q_cmd, std::span<const double> q_now,
                                   std::span<const double> jac, std::span<const double> lower,
                                   std::span<const double> upper, const ActionNoiseConfig& config,
                                   Rng& rng) {
  const size_t n = q_cmd.size();
  if (q_now.size() != n || lower.size() != n || upper.size() != n || jac.size() != 6 * n) {
    // A bug check, not bad input: the caller sizes every span from the same robot.
    throw std::logic_error("NoisyArmTarget: sizes do not match");
  }
  std::vector<double> q(q_cmd.begin(), q_cmd.end());
  if (config.enabled) {
    double dx2 = 0;
    for (int r = 0; r < 3; ++r) {
      double s = 0;
      for (size_t k = 0; k < n; ++k) s += jac[r * n + k] * (q_cmd[k] - q_now[k]);
      dx2 += s * s;
    }
    const double sigma_p = config.action_scale_factor * std::sqrt(dx2);
    const double sigma_r = config.rotation_noise_scale * sigma_p;
    std::array<double, 6> noise{};
    for (int i = 0; i < 3; ++i)
      noise[i] = rng.TruncatedNormal(sigma_p, config.max_tcp_position_noise);
    for (int i = 3; i < 6; ++i)
      noise[i] = rng.TruncatedNormal(sigma_r, config.max_tcp_rotation_noise);
    if (sigma_p > 0) {
      const std::vector<double> dq = robots::DampedLeastSquares(jac, n, noise, 1e-6);
      for (size_t k = 0; k < n; ++k) q[k] += dq[k];
    }
  }
  for (size_t k = 0; k < n; ++k) q[k] = std::clamp(q[k], lower[k], upper[k]);
  return q;
}

}  // namespace mlspaces::datagen
