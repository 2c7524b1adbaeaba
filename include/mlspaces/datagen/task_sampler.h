// Task samplers: the per-episode part of pick task sampling (spec section 3; docs/datagen.md).
//
// SampleTask(env, episode) runs the hooks in order on one Rng seeded with
// EpisodeSeed(run seed, env.scene_key(), episode):
//   1. RandomizeScene(env, rng)      default: env.Reset() + U(+-noise) on the arm joints
//                                    (robot_config.init_qpos_noise_range), servo targets too;
//   2. mj_forward;
//   3. SelectPickupObject(env, rng)  default: task_config.pickup_obj_name when set, else the
//                                    candidates (top-level free bodies outside the robot)
//                                    in turn, one per call;
//   4. SampleAndPlaceRobot(env, rng, draft)  (pure virtual; the tutorial's override point):
//                                    move the robot base and/or the object and fill the
//                                    draft's robot_base_pose, pickup_obj_start_pose and
//                                    pickup_obj_goal_pose;
//   5. mj_forward; then every required field is checked: a missing or malformed one is an
//      mlspaces::Error naming the sampler and the field, never a failed episode.
// Samplers are created through a TaskSamplerRegistry (a value; explicit registration).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"

namespace mlspaces::datagen {

/// The seed of one episode: DeriveSeed(run_seed, {HashString(scene_key), episode}).
MLSPACES_API uint64_t EpisodeSeed(uint64_t run_seed, std::string_view scene_key, int64_t episode);

/// Thrown by a hook that cannot place this episode's task (no room for the robot, object
/// unreachable, ...): the attempt is journaled as "sampler_reject" and the run goes on with
/// the next episode. Any other exception from a hook is a bug or bad input and stops the run.
class MLSPACES_API TaskRejected : public Error {
 public:
  using Error::Error;
};

/// The joint of an open / close task (tasks/open_close.h): MJCF name, the asset's name for it
/// (its joint-grasp file), the range and the closed limit, and the initial position.
struct MLSPACES_API TaskJoint {
  std::string name;
  std::string asset_joint;
  double range_lo = 0, range_hi = 0;
  double closed = 0;  ///< the range limit nearest 0 (0 when a limit is 0)
  double open = 0;    ///< the other limit
  double start = 0;   ///< qpos written by the sampler
};

/// The place target of a pick-and-place task (tasks/pick_and_place/sampler.h): the receptacle
/// body (or, "next to", the scene object), its start pose, and for the colour variant its
/// colour name and the distractor receptacles.
struct MLSPACES_API TaskPlace {
  std::string receptacle;
  Pose receptacle_start_pose;
  std::string color;                           ///< pick_and_place_color: the target's colour
  std::vector<std::string> other_receptacles;  ///< pick_and_place_color: the distractors
  std::vector<Pose> other_receptacle_start_poses;
};

/// What the hooks fill; every field but `joint` is required after the hooks ran (`joint`:
/// by task types open and close).
struct MLSPACES_API TaskDraft {
  std::optional<std::string> pickup_obj_name;
  std::optional<Pose> robot_base_pose;
  std::optional<Pose> pickup_obj_start_pose;
  std::optional<Pose> pickup_obj_goal_pose;
  std::optional<TaskJoint> joint;
  std::optional<TaskPlace> place;
};

/// A sampled task, fixed once sampled. Poses: world, xyz + quat wxyz.
struct MLSPACES_API Task {
  std::string pickup_obj_name;
  Pose robot_base_pose;
  Pose pickup_obj_start_pose;
  Pose pickup_obj_goal_pose;
  std::optional<TaskJoint> joint;  ///< open / close
  std::optional<TaskPlace> place;  ///< pick_and_place*
  int64_t episode = 0;
  uint64_t seed = 0;
};

class MLSPACES_API TaskSampler {
 public:
  // ===========================================================================================
  // Construction

  TaskSampler(ExperimentConfig config, uint64_t run_seed);
  virtual ~TaskSampler() = default;
  TaskSampler(const TaskSampler&) = delete;
  TaskSampler& operator=(const TaskSampler&) = delete;

  // ===========================================================================================
  // Sampling

  /// Samples episode `episode` in `env` (reset and randomised here; the model is reused).
  /// @throws Error naming the sampler and the field a hook left unset or malformed, or an
  /// Error from a hook.
  Task SampleTask(Env& env, int64_t episode);

  /// Called once for each Env this sampler will sample in, right after the Env is created
  /// and before anything else uses it (the Python binding shares the Env's model and data
  /// with Python here). Default: nothing.
  virtual void PrepareEnv(Env& env) { (void)env; }

  /// Called on each scene before the robot is inserted and it is compiled (the original's
  /// add_auxiliary_objects): pick-and-place adds its receptacles here. Default: nothing.
  virtual void AddAuxiliaryObjects(sim::Scene& scene) { (void)scene; }

  // ===========================================================================================
  // Access (references valid while the sampler lives)

  /// The name it was created under ("" when constructed directly).
  const std::string& name() const { return name_; }
  const ExperimentConfig& config() const { return config_; }
  uint64_t run_seed() const { return run_seed_; }
  /// Changes the run seed later episodes derive from (an evaluation env reseeded by reset).
  void set_run_seed(uint64_t seed) { run_seed_ = seed; }

  /// Candidate pickup objects: named top-level bodies with a free joint whose names do not
  /// start with the robot prefix, by body id.
  static std::vector<std::string> CandidateObjects(const Env& env);

 protected:
  // ===========================================================================================
  // Hooks (see the file comment for their order and defaults)

  virtual void RandomizeScene(Env& env, Rng& rng);
  virtual std::string SelectPickupObject(Env& env, Rng& rng);
  virtual void SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) = 0;

  /// The episode SampleTask is sampling (for the hooks; -1 outside SampleTask).
  int64_t episode() const { return episode_; }

  /// Run the hooks of another sampler, for this sampler's episode (a wrapper's inner
  /// sampler: the Python binding's sampler runs the engine sampler its Python class stands
  /// for).
  void RandomizeSceneOf(TaskSampler& inner, Env& env, Rng& rng) const {
    inner.episode_ = episode_;
    inner.RandomizeScene(env, rng);
  }
  std::string SelectPickupObjectOf(TaskSampler& inner, Env& env, Rng& rng) const {
    inner.episode_ = episode_;
    return inner.SelectPickupObject(env, rng);
  }
  void SampleAndPlaceRobotOf(TaskSampler& inner, Env& env, Rng& rng, TaskDraft& draft) const {
    inner.episode_ = episode_;
    inner.SampleAndPlaceRobot(env, rng, draft);
  }

 private:
  friend class TaskSamplerRegistry;
  ExperimentConfig config_;
  uint64_t run_seed_;
  std::string name_;
  int64_t task_counter_ = 0;
  int64_t episode_ = -1;
};

/// A scene of `config` as `mlspaces datagen` builds it: `scene_xml` composed, `sampler`'s
/// auxiliary objects added (pick-and-place: its receptacles), the config's robot inserted
/// and the whole compiled. The caller then calls sampler.PrepareEnv on the Env where it
/// keeps it. @throws Error as sim::Scene::Load, the sampler and Env::Create.
MLSPACES_API Env CreateSceneEnv(const ExperimentConfig& config, TaskSampler& sampler,
                                const std::filesystem::path& scene_xml, std::string scene_key);

/// `pose @ T(dx, dy, yaw)`: a planar move expressed in the frame of `pose` (the tutorial's
/// `pose @ random_pose`): pos += R (dx, dy, 0), quat = quat * RotZ(yaw). yaw in radians.
MLSPACES_API Pose ComposePlanar(const Pose& pose, double dx, double dy, double yaw);

/// The built-in config-driven sampler: the tutorial's BlockPickupTaskSampler. The robot base
/// and then the pickup object move by task_sampler_config.robot_base_noise / object_noise
/// (draws x, y, yaw for the robot, then x, y, yaw for the object, each U(-a, a)), composed on
/// their current poses; goal = start + goal_offset_z along world z.
class MLSPACES_API BlockPickupTaskSampler : public TaskSampler {
 public:
  using TaskSampler::TaskSampler;

 protected:
  void SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) override;
};

using TaskSamplerFactory =
    std::function<std::unique_ptr<TaskSampler>(const ExperimentConfig& config, uint64_t seed)>;

/// Task samplers by name; names compare case-insensitively.
class MLSPACES_API TaskSamplerRegistry {
 public:
  /// An empty registry.
  TaskSamplerRegistry() = default;
  /// A registry holding the built-in samplers ("block_pickup").
  static TaskSamplerRegistry WithBuiltins();

  /// @throws UsageError for an empty name or one already registered (any case). The factory
  /// must not return null (Create throws Error then).
  void Register(std::string_view name, TaskSamplerFactory factory);
  bool Contains(std::string_view name) const;
  /// Registered names as given, sorted case-insensitively.
  std::vector<std::string> names() const;

  /// Creates sampler `name`: never null, owned by the caller. @throws Error (field
  /// /task_sampler_config/task_sampler_class) listing the valid names for an unknown one.
  std::unique_ptr<TaskSampler> Create(std::string_view name, const ExperimentConfig& config,
                                      uint64_t run_seed) const;
  /// Creates config.task_sampler_config.task_sampler_class.
  std::unique_ptr<TaskSampler> Create(const ExperimentConfig& config, uint64_t run_seed) const;

 private:
  struct Entry {
    std::string name;
    TaskSamplerFactory factory;
  };
  std::map<std::string, Entry> entries_;  // key: lower-case name
};

}  // namespace mlspaces::datagen
