#include "mlspaces/datagen/action_noise.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace mlspaces::datagen {
namespace {

// A 6 x 7 Jacobian with full row rank: identity on the first 6 joints plus a coupled 7th.
std::vector<double> Jacobian() {
  std::vector<double> jac(42, 0.0);
  for (int r = 0; r < 6; ++r) jac[r * 7 + r] = 1.0;
  for (int r = 0; r < 6; ++r) jac[r * 7 + 6] = 0.1 * (r + 1);
  return jac;
}

const std::vector<double> kLower(7, -std::numeric_limits<double>::infinity());
const std::vector<double> kUpper(7, std::numeric_limits<double>::infinity());

// J (q - q_cmd): the task-space perturbation the noise made.
std::vector<double> TaskDelta(const std::vector<double>& q, const std::vector<double>& q_cmd) {
  const std::vector<double> jac = Jacobian();
  std::vector<double> dx(6, 0.0);
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 7; ++k) dx[r] += jac[r * 7 + k] * (q[k] - q_cmd[k]);
  return dx;
}

TEST(ActionNoiseTest, DisabledOnlyClipsToTheLimits) {
  ActionNoiseConfig config;
  config.enabled = false;
  Rng rng(1);
  const std::vector<double> cmd = {0.5, -2, 0, 0, 0, 0, 3};
  const std::vector<double> lower(7, -1.0), upper(7, 1.0);
  const std::vector<double> q =
      NoisyArmTarget(cmd, std::vector<double>(7, 0.0), Jacobian(), lower, upper, config, rng);
  EXPECT_EQ(q, (std::vector<double>{0.5, -1, 0, 0, 0, 0, 1}));
}

TEST(ActionNoiseTest, NoMotionMeansNoNoise) {
  ActionNoiseConfig config;  // enabled by default, as in the original
  Rng rng(2);
  const std::vector<double> q0 = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7};
  EXPECT_EQ(NoisyArmTarget(q0, q0, Jacobian(), kLower, kUpper, config, rng), q0);
}

TEST(ActionNoiseTest, NoiseScalesWithTheCommandedMotionAndIsBounded) {
  ActionNoiseConfig config;
  Rng rng(3);
  const std::vector<double> now(7, 0.0);
  // A command that moves the TCP 1 cm: sigma_p = 1 mm, sigma_r = 0.1 mm.
  std::vector<double> cmd(7, 0.0);
  cmd[0] = 0.01;
  double sum2_pos = 0, sum2_rot = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const std::vector<double> dx =
        TaskDelta(NoisyArmTarget(cmd, now, Jacobian(), kLower, kUpper, config, rng), cmd);
    for (int r = 0; r < 3; ++r) {
      sum2_pos += dx[r] * dx[r];
      EXPECT_LE(std::abs(dx[r]), config.max_tcp_position_noise + 1e-9);
    }
    for (int r = 3; r < 6; ++r) sum2_rot += dx[r] * dx[r];
  }
  EXPECT_NEAR(std::sqrt(sum2_pos / (3 * n)), 0.001, 0.00005);
  EXPECT_NEAR(std::sqrt(sum2_rot / (3 * n)), 0.0001, 0.000005);
  // A huge command: the draws are truncated at the configured bounds.
  cmd[0] = 10.0;
  for (int i = 0; i < 1000; ++i) {
    const std::vector<double> dx =
        TaskDelta(NoisyArmTarget(cmd, now, Jacobian(), kLower, kUpper, config, rng), cmd);
    for (int r = 0; r < 3; ++r) EXPECT_LE(std::abs(dx[r]), config.max_tcp_position_noise + 1e-9);
    for (int r = 3; r < 6; ++r) EXPECT_LE(std::abs(dx[r]), config.max_tcp_rotation_noise + 1e-9);
  }
}

TEST(ActionNoiseTest, SameSeedSameNoise) {
  ActionNoiseConfig config;
  const std::vector<double> now(7, 0.0);
  std::vector<double> cmd(7, 0.05);
  Rng a(9), b(9), c(10);
  const auto qa = NoisyArmTarget(cmd, now, Jacobian(), kLower, kUpper, config, a);
  EXPECT_EQ(qa, NoisyArmTarget(cmd, now, Jacobian(), kLower, kUpper, config, b));
  EXPECT_NE(qa, NoisyArmTarget(cmd, now, Jacobian(), kLower, kUpper, config, c));
}

TEST(ActionNoiseTest, MismatchedSizesThrow) {
  ActionNoiseConfig config;
  Rng rng(1);
  EXPECT_THROW(NoisyArmTarget(std::vector<double>(7, 0), std::vector<double>(6, 0), Jacobian(),
                              kLower, kUpper, config, rng),
               std::logic_error);  // a bug check
}

}  // namespace
}  // namespace mlspaces::datagen
