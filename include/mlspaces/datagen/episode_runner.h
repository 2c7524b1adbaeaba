// One pick episode end to end: sample the task, load the object's grasps, plan, then step
// policy -> controller -> physics until the planner is done or the horizon runs out, judging
// success on the final state and recording every observation (spec 6-8, 11.3).
//
// Per policy step: the planner's action; arm targets get the configured action noise (drawn
// from the episode's own Rng); the gripper ctrl is set; then policy_dt / sim_dt physics steps,
// each mj_step1 -> arm gravity compensation -> mj_step2; then the observation is recorded.
// Observation 0 is the state after sampling; row i of the actions is the action that led to
// observation i (row 0 a dummy `{}`, the last row the `done` action when the plan finished).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/camera_recorder.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_record.h"
#include "mlspaces/datagen/journal.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/datagen/tasks/pick/pick_planner.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/robots/robot_view.h"

namespace mlspaces::datagen {

/// The outcome of one episode.
// NOLINTNEXTLINE(bugprone-exception-escape): flags the implicit special members
struct MLSPACES_API EpisodeResult {
  /// The journal line: outcome, message, per-stage timings (sample, grasps, plan, policy,
  /// physics, observe), and extra figures (lift, retries, grasp index, steps).
  AttemptRecord attempt;
  bool success = false;
  /// The recorded trajectory; set when the rollout ran (whatever its outcome) and recording
  /// is on.
  std::optional<EpisodeRecord> record;
  int64_t policy_steps = 0;
  int64_t physics_steps = 0;
  /// Set when the attempt failed for a reason of the input files (the pickup object's
  /// asset_id or grasp file: preflight.h) that every attempt on that object hits; it names
  /// the file and the field.
  std::optional<Error> input_error;
};

struct MLSPACES_API EpisodeRunnerOptions {
  /// Scene name in records and the journal, e.g. "house_0".
  std::string scene_name = "house_0";
  /// Record observations (off: only the outcome, for benchmarks of the bare loop).
  bool record = true;
  /// Where camera videos go (the work item's folder). Cameras are rendered when this is set,
  /// recording is on, task_config.enable_rendering and use_sensors are true and the camera
  /// config has cameras; the videos keep CameraRecorder::TempVideoName names until the
  /// episode is kept (see RunDatagen).
  std::filesystem::path video_dir;
  sim::GlBackend gl_backend = sim::GlBackend::kOsMesa;
  /// The data hash recorded in provenance (DataConfigHashHex of the config, which reads the
  /// libraries' files); empty: computed when the first episode is recorded.
  std::string config_hash;
  /// Called once per policy step after the controller wrote ctrl, right before the physics
  /// steps (for custom logging, or replaying the exact states in a benchmark). Must not
  /// modify the data.
  std::function<void(const mjModel*, const mjData*, int64_t step)> on_step;
};

class MLSPACES_API EpisodeRunner {
 public:
  // ===========================================================================================
  // Construction

  /// `env`, `sampler` and `registry` must outlive the runner. Builds the robot view and the
  /// planner (IK solver, grasp collision probe) once. @throws Error for a config the env
  /// cannot run (policy_dt not a multiple of sim_dt, a robot element missing).
  EpisodeRunner(Env& env, TaskSampler& sampler, const Registry& registry,
                const ExperimentConfig& config, EpisodeRunnerOptions options = {});
  ~EpisodeRunner();

  // ===========================================================================================
  // Running

  /// Runs episode `episode` (its seed: EpisodeSeed(run seed, scene key, episode)).
  /// A hook's TaskRejected gives outcome sampler_reject; other sampler errors propagate.
  EpisodeResult Run(int64_t episode);

  // ===========================================================================================
  // Access

  /// The robot's handles; valid while the runner lives.
  const robots::RobotView& robot() const { return robot_; }
  /// Physics steps per policy step (policy_dt_ms / sim_dt_ms).
  int substeps() const { return substeps_; }
  /// The camera recorder, or null when cameras are off; owned by the runner, valid while it
  /// lives.
  const CameraRecorder* cameras() const { return cameras_.get(); }

 private:
  struct Impl;
  /// The state of one episode while Run carries it through the steps below.
  struct Episode;

  // Run's steps, in order. The first three return false when the episode ends there (the
  // outcome is in the attempt).
  bool SampleTask(Episode& e);
  bool LoadGrasps(Episode& e);
  bool Plan(Episode& e);
  /// Sets up the recorded series (robot poses, env states of the free objects).
  void BeginRecording(Episode& e);
  /// Steps policy -> controller -> physics until done or the horizon, observing each state.
  void Rollout(Episode& e);
  /// Records the observation after e.step policy steps; `action` led to it (null for
  /// observation 0).
  void Observe(Episode& e, const PlannerAction* action);
  /// Records the action rows of one observation (see Observe).
  void RecordActions(Episode& e, const PlannerAction* action, const Mat4& base_inv);
  /// The outcome from the final verdict and the planner's state.
  void Judge(Episode& e);
  /// The episode's metadata and obs_scene; moves the record into the result.
  void FinishRecord(Episode& e);
  /// The TCP pose in the world frame with the arm joints at `q` (the rest as now).
  Mat4 CommandedTcp(const std::vector<double>& q);

  Env& env_;
  TaskSampler& sampler_;
  const Registry& registry_;
  ExperimentConfig config_;
  EpisodeRunnerOptions options_;
  robots::RobotView robot_;
  // The task family's planner (tasks/task_family.h).
  std::unique_ptr<PickPlanner> planner_owned_;
  PickPlanner& planner_;
  int substeps_ = 1;
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<CameraRecorder> cameras_;
};

}  // namespace mlspaces::datagen
