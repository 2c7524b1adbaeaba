// The open / close task sampler (spec A.3.2-3.3; docs/tasks.md), registered as
// "OpenTaskSampler" (the original's name) for task_type open and close.
//
// Per episode, on the episode's Rng (so an episode never depends on the ones before it):
//   1. RandomizeScene (the base's: reset, arm init noise);
//   2. the articulated object: task_config.pickup_obj_name, else one drawn uniformly among the
//      scene metadata's objects with at least one usable joint (below);
//   3. the joint: task_config.joint_name, else one drawn uniformly among the object's usable
//      joints: hinge or slide joints of the object's subtree with a range whose asset joint
//      name (metadata objects.<body>.name_map.joints.<mjcf joint>, else the MJCF name) has a
//      joint-grasp file in policy_config.grasp_libraries;
//   4. its initial position: closed + p (open - closed), p =
//      task_sampler_config.target_initial_state_open_percentage (null: 0 open, 0.5 close);
//      closed = the range limit nearest 0, open = the other one (two-sided ranges work);
//   5. the robot base: task_sampler_config.robot_base_noise composed on the scene's pose
//      (as block_pickup); a robot geom within 2 cm of the joint body's (a door half open
//      toward the robot) draws the hand back toward the base (IK, 1 cm steps, up to 15 cm)
//      until 2 cm clear, else TaskRejected; start and goal pose = the object's root pose
//      (it does not move).
// A scene without a usable joint is an Error naming the scene metadata file and the field.
#pragma once

#include "mlspaces/core/export.h"

#include <memory>
#include <string>
#include <vector>

#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/library/registry.h"

namespace mlspaces::datagen {

/// One usable joint of an articulated object.
struct MLSPACES_API ArticulatedJoint {
  int joint_id = -1;  ///< MuJoCo joint id
  int index = 0;      ///< index among the object's joints (the original's joint_index)
  TaskJoint joint;    ///< name, asset name, range, closed / open limits (start unset)
};

/// The joints of `object_body`'s subtree that are hinge or slide with a range, with their
/// closed / open limits and asset names (metadata name_map), in joint-id order. Grasp files
/// are not checked.
MLSPACES_API std::vector<ArticulatedJoint> ArticulatedJoints(const Env& env,
                                                             const std::string& object_body);

class MLSPACES_API OpenTaskSampler : public TaskSampler {
 public:
  /// Builds its own Registry from config.libraries (for the joint-grasp lookups).
  OpenTaskSampler(const ExperimentConfig& config, uint64_t run_seed);
  ~OpenTaskSampler() override;

 protected:
  std::string SelectPickupObject(Env& env, Rng& rng) override;
  void SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) override;

 private:
  /// The usable joints of `body` (those with a joint-grasp file).
  std::vector<ArticulatedJoint> UsableJoints(const Env& env, const std::string& body);

  std::unique_ptr<Registry> registry_;
};

/// Registers "OpenTaskSampler" in `registry`.
MLSPACES_API void RegisterOpenCloseSamplers(TaskSamplerRegistry& registry);

/// True for task types open and close.
MLSPACES_API bool IsOpenCloseTask(TaskType type);

}  // namespace mlspaces::datagen
