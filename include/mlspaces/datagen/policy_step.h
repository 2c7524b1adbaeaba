// One policy step as the datagen rollout makes it, shared by EpisodeRunner (the planner's
// actions) and EvalEnv (outside actions), so a replayed episode steps exactly as it was
// recorded: the step counts of the config, the episode's own action-noise stream, the
// controller's noisy arm targets, then the physics.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/robots/robot_view.h"

namespace mlspaces::datagen {

/// Physics steps per policy step: policy_dt_ms / sim_dt_ms.
/// @throws Error (field policy_dt_ms) when that is not a whole number >= 1.
MLSPACES_API int PolicySubsteps(const ExperimentConfig& config);

/// @throws Error (file `scene`, field sim_dt_ms) when the model's timestep is not sim_dt_ms
/// (the scene's own timestep rules the physics: say so instead of silently differing).
MLSPACES_API void CheckSimTimestep(const mjModel* m, const ExperimentConfig& config,
                                   const std::string& scene);

/// The action-noise stream of the episode with seed `episode_seed`.
MLSPACES_API Rng EpisodeNoiseRng(uint64_t episode_seed);

/// The controller: the arm targets for commanded joints `arm` with the configured action noise
/// drawn from `rng` (NoisyArmTarget at the current joints and Jacobian).
MLSPACES_API std::vector<double> ControllerArmTargets(const robots::RobotView& robot,
                                                      const mjData* d, std::span<const double> arm,
                                                      const ActionNoiseConfig& noise, Rng& rng);

/// The physics of one policy step: arm targets and gripper ctrl set, `before_physics` (if
/// any), `substeps` physics steps, then mj_fwdPosition (positions, contacts and Jacobians of
/// the new state for the success check, the recorder and the next action).
MLSPACES_API void StepPhysics(const robots::RobotView& robot, const mjModel* m, mjData* d,
                              std::span<const double> arm_targets, double gripper, int substeps,
                              const std::function<void()>& before_physics = {});

}  // namespace mlspaces::datagen
