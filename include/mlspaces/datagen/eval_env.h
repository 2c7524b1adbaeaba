// An evaluation environment: the datagen scene, robot and task sampler, driven by outside
// actions one policy step at a time (the Python package's gymnasium env wraps it).
//
// Reset(seed, house, episode) loads the house's scene (once per house), samples the task of
// `episode` exactly as a datagen run with run seed `seed` samples it, and observes. Step(arm,
// gripper) is one policy step as the datagen rollout makes it: the arm targets get the
// configured action noise (drawn from the episode's own noise Rng, as in datagen), the gripper
// ctrl is set, then policy_dt / sim_dt physics steps and the success check. So replaying a
// recorded episode's commanded actions after Reset with its run seed and episode number
// reproduces its states.
//
// Lifetimes: references returned (env(), robot(), task(), camera names) are valid until the
// next Reset or the EvalEnv's end.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/camera_recorder.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/object_image_points.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/datagen/tasks/pick/success.h"
#include "mlspaces/robots/robot_view.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::datagen {

class TaskEpisode;  // tasks/task_family.h

struct MLSPACES_API EvalEnvOptions {
  /// Render the configured cameras (Render()); off: no GL context is made.
  bool render = true;
  sim::GlBackend gl_backend = sim::GlBackend::kOsMesa;
};

/// What one step did.
struct MLSPACES_API EvalStep {
  PickSuccess verdict;     ///< the success check on the new state
  bool truncated = false;  ///< the task horizon is reached
};

class MLSPACES_API EvalEnv {
 public:
  // ===========================================================================================
  // Construction

  /// `config` must be valid (Validate); `sampler` samples the tasks (never null).
  /// @throws Error for a config the env cannot run (policy_dt not a multiple of sim_dt).
  EvalEnv(ExperimentConfig config, std::unique_ptr<TaskSampler> sampler,
          EvalEnvOptions options = {});
  ~EvalEnv();
  EvalEnv(const EvalEnv&) = delete;
  EvalEnv& operator=(const EvalEnv&) = delete;

  // ===========================================================================================
  // Episodes

  /// Loads house `house` (an index into scene_xml_paths) if it is not the loaded one: its
  /// scene, robot and cameras; no task yet (robot() and camera_names() are valid after it).
  /// @throws Error for a bad house or scene.
  void LoadHouse(int64_t house);
  /// Starts episode `episode` of house `house` (an index into scene_xml_paths) with run seed
  /// `seed`. @throws TaskRejected when the sampler rejects the task, Error for a bad house or
  /// scene, or what a sampler hook throws.
  void Reset(uint64_t seed, int64_t house, int64_t episode);
  /// One policy step with arm joint targets (radians; changes from the current joints in
  /// joint_rel_position mode) and the gripper ctrl (0 open .. 255 closed).
  /// @throws Error before the first Reset or for a wrong number of arm values.
  EvalStep Step(std::span<const double> arm, double gripper);

  // ===========================================================================================
  // State (valid after Reset)

  /// A task was sampled (Reset ran).
  bool started() const { return task_.episode >= 0 && env_ != nullptr && task_episode_ != nullptr; }
  const Env& env() const;
  const robots::RobotView& robot() const;
  const Task& task() const { return task_; }
  const ExperimentConfig& config() const { return config_; }
  /// The success check of the current state (after Reset: of the sampled state).
  const PickSuccess& verdict() const { return verdict_; }
  int64_t steps() const { return steps_; }
  int64_t house() const { return house_; }

  // ===========================================================================================
  // Cameras

  /// The configured cameras (empty before the first Reset or without rendering).
  std::vector<std::string> camera_names() const;
  int image_width() const { return config_.camera_config.img_resolution[0]; }
  int image_height() const { return config_.camera_config.img_resolution[1]; }
  /// Renders camera `index` at the current state into `rgb` (height*width*3 bytes, rows top
  /// to bottom). @throws Error for a bad index or when rendering is off.
  void Render(size_t index, unsigned char* rgb);
  /// One observation's frames, as the datagen recorder renders them: every camera at the
  /// current state, camera i into rgb[i] (as Render). With `points` (may be null) and
  /// camera_config.object_image_points, (*points)[i] = the image points of
  /// image_point_objects() in camera i (empty for "follower" cameras), drawn from the
  /// episode's own stream in the recorder's order: the observations of a replayed episode
  /// carry its dataset's points. Render calls draw none.
  /// @throws Error before Reset, when rendering is off, or for rgb.size() != cameras.
  void Observe(std::span<unsigned char* const> rgb, std::vector<std::vector<ImagePoints>>* points);
  /// The objects whose image points Observe draws (TaskObjects of the episode; empty without
  /// cameras or with camera_config.object_image_points off).
  std::vector<TrackedObject> image_point_objects() const;

 private:
  /// The renderer made (on first use) and shadow views set for the state's cameras.
  std::vector<sim::CameraView> PrepareViews();

  ExperimentConfig config_;
  std::unique_ptr<TaskSampler> sampler_;
  EvalEnvOptions options_;
  int substeps_ = 1;
  int64_t house_ = -1;
  std::unique_ptr<Env> env_;
  std::unique_ptr<robots::RobotView> robot_;
  std::unique_ptr<CameraSystem> cameras_;
  CameraSystemConfig camera_config_;  // the house's cameras (the config's or the robot's)
  std::unique_ptr<sim::Renderer> renderer_;
  Task task_;  // episode -1 until Reset (set in the constructor)
  int object_ = -1;
  Rng noise_rng_{0};
  PickSuccess verdict_;
  std::unique_ptr<TaskEpisode> task_episode_;  // the episode's, as its family judges it
  std::unique_ptr<ObjectImagePoints> points_;  // the episode's tracked objects, or null
  Rng points_rng_{0};
  int64_t steps_ = 0;
};

}  // namespace mlspaces::datagen
