#include "mlspaces/datagen/policy_step.h"

#include <cmath>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/action_noise.h"

namespace mlspaces::datagen {

int PolicySubsteps(const ExperimentConfig& config) {
  const double ratio = config.policy_dt_ms / config.sim_dt_ms;
  const int substeps = static_cast<int>(std::lround(ratio));
  if (substeps < 1 || std::abs(ratio - substeps) > 1e-9) {
    throw Error("policy_dt_ms must be a whole multiple of sim_dt_ms", "", "policy_dt_ms");
  }
  return substeps;
}

void CheckSimTimestep(const mjModel* m, const ExperimentConfig& config, const std::string& scene) {
  if (std::abs(m->opt.timestep * 1000.0 - config.sim_dt_ms) > 1e-9) {
    throw Error("the scene's timestep is " + std::to_string(m->opt.timestep * 1000.0) +
                    " ms but sim_dt_ms is " + std::to_string(config.sim_dt_ms),
                scene, "sim_dt_ms");
  }
}

Rng EpisodeNoiseRng(uint64_t episode_seed) {
  return Rng(DeriveSeed(episode_seed, {0x6e6f697365ULL}));  // "noise"
}

std::vector<double> ControllerArmTargets(const robots::RobotView& robot, const mjData* d,
                                         std::span<const double> arm,
                                         const ActionNoiseConfig& noise, Rng& rng) {
  const std::vector<double> q_now = robot.ArmQpos(d);
  const std::vector<double> jac = robot.ArmJacobian(d);
  return NoisyArmTarget(arm, q_now, jac, robot.arm_lower(), robot.arm_upper(), noise, rng);
}

void StepPhysics(const robots::RobotView& robot, const mjModel* m, mjData* d,
                 std::span<const double> arm_targets, double gripper, int substeps,
                 const std::function<void()>& before_physics) {
  robot.SetArmTargets(d, arm_targets);
  robot.SetGripperCtrl(d, gripper);
  if (before_physics) before_physics();
  robot.Step(d, substeps);
  mj_fwdPosition(m, d);
}

}  // namespace mlspaces::datagen
