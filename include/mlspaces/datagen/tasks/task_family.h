// Task families (docs/tasks.md "Adding a task"): what the episode runner and the gym env ask
// of a task type. Each family lives in its own folder under tasks/ (pick, open_close,
// pick_and_place) with its sampler, planner, success rule and a TaskEpisode; task_family.cc
// lists the families. The runner and EvalEnv hold no branch per task type.
//
// An episode's life, as EpisodeRunner drives it: the sampler draws a Task; the family makes a
// TaskEpisode from it (checking what the family needs: a joint, a place target); LoadGrasps;
// Plan on the family's planner; then per observation Judge (success, reward) and Record
// (task_info and the family's series); at the end FailureMessage when the plan finished
// without success, and Description / AddToObsScene for the record.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mlspaces/core/json.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_record.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/datagen/tasks/pick/pick_planner.h"
#include "mlspaces/datagen/tasks/pick/success.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/grasp_set.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/robots/robot_view.h"

namespace mlspaces::datagen {

// =============================================================================================
// One episode's task

/// The task of one episode as its family plans, judges and records it. Made by
/// TaskFamily::make_episode from a sampled Task; keeps ids into the env's model and a
/// reference to the config, so the env and the config must outlive it.
class MLSPACES_API TaskEpisode {
 public:
  virtual ~TaskEpisode();

  /// The pickup object's body id.
  int object() const { return object_; }
  /// The task as sampled.
  const Task& task() const { return task_; }

  // -------------------------------------------------------------------------------------------
  // Before the rollout

  /// Adds what the attempt records about the sampled task (e.g. "joint") to `extra`.
  virtual void AddSampleInfo(Json& extra) const;
  /// The grasps to plan with, of asset `uid` (the pickup object's). Default: the object's
  /// rigid grasps (LoadPickupGrasps). @throws Error naming the file and field of bad input.
  virtual GraspSet LoadGrasps(const Registry& registry, const std::string& uid,
                              const std::filesystem::path& metadata_file,
                              const std::vector<std::string>& filter) const;
  /// Starts `planner` (the one the family's make_planner built) on the state `d`.
  virtual PlanFailure Plan(PickPlanner& planner, const mjData* d,
                           std::vector<Mat4> grasps) const = 0;
  /// Adds what the attempt records about a plan that succeeded to `extra`.
  virtual void AddPlanInfo(const PickPlanner& planner, Json& extra) const;

  // -------------------------------------------------------------------------------------------
  // Each observation

  /// Declares the family's per-step series in `rec` (before the first Record).
  virtual void DeclareSeries(EpisodeRecord& rec) const;
  /// Judges the state `d` (current: after mj_forward or a step): sets verdict.success and
  /// verdict.reward where the family decides them (pick keeps EvaluatePickSuccess's). Called
  /// once per observation, in order (a family may keep memory across calls).
  virtual void Judge(const mjData* d, PickSuccess& verdict) = 0;
  /// Appends the step's task_info entry and the family's series to `rec`, for the verdict
  /// that Judge just gave on `d`.
  virtual void Record(EpisodeRecord& rec, const mjData* d, int64_t step,
                      const PickSuccess& verdict) const = 0;

  // -------------------------------------------------------------------------------------------
  // After the rollout

  /// Adds what the attempt records about the rollout to `extra` (after `step` policy steps).
  virtual void AddRolloutInfo(Json& extra, int64_t step) const;
  /// Why a plan that ran to its end did not succeed (the attempt's message), at `step`.
  virtual std::string FailureMessage(const PickSuccess& verdict, int64_t step) const = 0;
  /// The task description, with `pickup` the object's referral expression.
  virtual std::string Description(const Registry& registry, const std::string& pickup) const = 0;
  /// Adds the family's keys to obs_scene (which holds pick's: text, referral expressions,
  /// frozen_config).
  virtual void AddToObsScene(const Registry& registry, const std::string& pickup,
                             Json& obs_scene) const;

 protected:
  /// `env` and `config` must outlive the episode.
  TaskEpisode(const Env& env, const ExperimentConfig& config, Task task);

  const Env& env_;
  const ExperimentConfig& config_;
  Task task_;
  int object_ = -1;
};

// =============================================================================================
// Families

/// A family of task types: its planner and its episodes.
struct MLSPACES_API TaskFamily {
  /// The folder under tasks/, e.g. "open_close".
  std::string_view name;
  /// True for the task types of the family.
  bool (*has_type)(TaskType type) = nullptr;
  /// The family's planner, built once per runner.
  std::unique_ptr<PickPlanner> (*make_planner)(const Env& env, const robots::RobotView& robot,
                                               const ExperimentConfig& config) = nullptr;
  /// The episode of a sampled task. `sampler` names the sampler in errors. @throws Error
  /// when the task lacks what the family needs (a joint, a place target) or names no body or
  /// joint of the env.
  std::unique_ptr<TaskEpisode> (*make_episode)(const Env& env, const ExperimentConfig& config,
                                               Task task, std::string_view sampler) = nullptr;
  /// Why the config's `sampler_class` (task_sampler_config.task_sampler_class, any case)
  /// cannot sample task type `type` of the family, or "" when it may.
  std::string (*sampler_refusal)(TaskType type, std::string_view sampler_class) = nullptr;
  /// True for the sampler classes (any case) that sample only this family's task types
  /// (config validation refuses them with another family's type).
  bool (*owns_sampler)(std::string_view sampler_class) = nullptr;
};

/// TaskFamily::make_planner for a planner built as PickPlanner is (env, robot, the policy
/// config, policy_dt in seconds).
template <class Planner>
std::unique_ptr<PickPlanner> MakeFamilyPlanner(const Env& env, const robots::RobotView& robot,
                                               const ExperimentConfig& config) {
  return std::make_unique<Planner>(env, robot, config.policy_config, config.policy_dt_ms / 1000.0);
}

/// TaskFamily::make_episode for an episode constructed from (env, config, task, sampler).
template <class Episode>
std::unique_ptr<TaskEpisode> MakeFamilyEpisode(const Env& env, const ExperimentConfig& config,
                                               Task task, std::string_view sampler) {
  return std::make_unique<Episode>(env, config, std::move(task), sampler);
}

/// The family of `type`. Every TaskType has one; @throws Error naming task_type for a value
/// outside the enum.
MLSPACES_API const TaskFamily& TaskFamilyOf(TaskType type);

/// Every family, in TaskFamilyOf's order.
MLSPACES_API std::span<const TaskFamily* const> TaskFamilies();

/// The referral expression of a body: its asset's category (`annotation`, may be null), else
/// the body name with underscores as spaces.
MLSPACES_API std::string Referral(const std::string& body, const Annotation* annotation);

}  // namespace mlspaces::datagen
