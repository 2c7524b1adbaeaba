#include "mlspaces/datagen/eval_env.h"

#include <cmath>
#include <string>
#include <utility>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/policy_step.h"
#include "mlspaces/datagen/tasks/task_family.h"
#include "mlspaces/sim/scene.h"

namespace mlspaces::datagen {
EvalEnv::EvalEnv(ExperimentConfig config, std::unique_ptr<TaskSampler> sampler,
                 EvalEnvOptions options)
    : config_(std::move(config)), sampler_(std::move(sampler)), options_(options) {
  if (!sampler_) throw Error("EvalEnv: no task sampler");
  substeps_ = PolicySubsteps(config_);
  task_.episode = -1;
}

EvalEnv::~EvalEnv() = default;

const Env& EvalEnv::env() const {
  if (!env_) throw Error("the evaluation env has no scene yet: call reset first");
  return *env_;
}

const robots::RobotView& EvalEnv::robot() const {
  if (!robot_) throw Error("the evaluation env has no scene yet: call reset first");
  return *robot_;
}

void EvalEnv::LoadHouse(int64_t house) {
  const auto& scenes = config_.task_sampler_config.scene_xml_paths;
  if (house < 0 || house >= static_cast<int64_t>(scenes.size())) {
    throw Error("house index " + std::to_string(house) + " out of range: the config has " +
                    std::to_string(scenes.size()) + " scene(s)",
                "", "task_sampler_config.scene_xml_paths");
  }
  if (house != house_ || !env_) {
    task_episode_.reset();
    points_.reset();
    renderer_.reset();
    cameras_.reset();
    robot_.reset();
    env_.reset();
    house_ = -1;
    const std::filesystem::path& xml = scenes[static_cast<size_t>(house)];
    env_ = std::make_unique<Env>(
        CreateSceneEnv(config_, *sampler_, xml, "house_" + std::to_string(house)));
    sampler_->PrepareEnv(*env_);
    CheckSimTimestep(env_->model(), config_, xml.string());
    robot_ = std::make_unique<robots::RobotView>(env_->model(), env_->robot());
    const CameraSystemConfig cameras = CamerasForRobot(config_.camera_config, env_->robot());
    if (options_.render && !cameras.cameras.empty()) {
      // The GL context comes with the first Render (a process that only builds the env, e.g.
      // the parent of forked vector-env workers, makes none).
      cameras_ = std::make_unique<CameraSystem>(env_->model(), cameras);
      camera_config_ = cameras;
    }
    house_ = house;
    task_ = Task{};
    task_.episode = -1;
  }
}

void EvalEnv::Reset(uint64_t seed, int64_t house, int64_t episode) {
  LoadHouse(house);
  sampler_->set_run_seed(seed);
  steps_ = 0;
  // Not started until the new episode is whole (a sampler or task error leaves none).
  task_episode_.reset();
  points_.reset();
  task_ = Task{};
  task_.episode = -1;
  Task task = sampler_->SampleTask(*env_, episode);
  std::unique_ptr<TaskEpisode> task_episode =
      TaskFamilyOf(config_.task_type).make_episode(*env_, config_, task, sampler_->name());
  if (cameras_ && config_.camera_config.object_image_points) {
    const robots::RobotSpec& robot = env_->robot();
    points_ = std::make_unique<ObjectImagePoints>(
        env_->model(), TaskObjects(env_->model(), task_episode->task(), config_.task_config,
                                   robot.prefix + robot.gripper_body));
    points_rng_ = ImagePointsRng(task.seed);
  }
  task_episode_ = std::move(task_episode);
  task_ = std::move(task);
  object_ = task_episode_->object();
  // The same noise stream as the datagen rollout of this episode.
  noise_rng_ = EpisodeNoiseRng(task_.seed);
  verdict_ =
      EvaluatePickSuccess(env_->model(), env_->data(), object_, task_.pickup_obj_start_pose.pos[2],
                          env_->robot().prefix, config_.task_config.succ_pos_threshold);
  task_episode_->Judge(env_->data(), verdict_);
}

EvalStep EvalEnv::Step(std::span<const double> arm, double gripper) {
  if (!started()) throw Error("step before reset: call reset first");
  const robots::RobotView& robot = *robot_;
  if (arm.size() != robot.num_arm()) {
    throw Error("the arm action has " + std::to_string(arm.size()) + " values, the robot " +
                    std::to_string(robot.num_arm()) + " joints",
                "", "arm");
  }
  if (!std::isfinite(gripper)) throw Error("the gripper action is not finite", "", "gripper");
  const mjModel* m = env_->model();
  mjData* d = env_->data();
  const std::vector<double> q_now = robot.ArmQpos(d);
  std::vector<double> q_cmd(arm.begin(), arm.end());
  for (size_t i = 0; i < q_cmd.size(); ++i) {
    if (!std::isfinite(q_cmd[i])) {
      throw Error("arm action value " + std::to_string(i) + " is not finite", "", "arm");
    }
    if (config_.robot_config.command_mode.arm == ArmCommandMode::kJointRelPosition) {
      q_cmd[i] += q_now[i];
    }
  }
  const std::vector<double> target =
      ControllerArmTargets(robot, d, q_cmd, config_.robot_config.action_noise_config, noise_rng_);
  StepPhysics(robot, m, d, target, gripper, substeps_);
  ++steps_;
  verdict_ = EvaluatePickSuccess(m, d, object_, task_.pickup_obj_start_pose.pos[2],
                                 env_->robot().prefix, config_.task_config.succ_pos_threshold);
  task_episode_->Judge(d, verdict_);
  EvalStep out;
  out.verdict = verdict_;
  out.truncated = steps_ >= config_.task_horizon;
  return out;
}

std::vector<std::string> EvalEnv::camera_names() const {
  std::vector<std::string> out;
  if (cameras_) {
    for (size_t i = 0; i < cameras_->size(); ++i) out.push_back(cameras_->name(i));
  }
  return out;
}

std::vector<sim::CameraView> EvalEnv::PrepareViews() {
  if (!cameras_) {
    throw Error(env_ ? "rendering is off (no cameras configured, or render=false)"
                     : "render before reset: call reset first");
  }
  if (!renderer_) {
    renderer_ = MakeCameraRenderer(env_->model(), camera_config_, options_.gl_backend);
  }
  // Every camera's view, so that the cameras of one state share its shadow maps.
  std::vector<sim::CameraView> views;
  for (size_t i = 0; i < cameras_->size(); ++i) views.push_back(cameras_->View(i, env_->data()));
  renderer_->SetShadowViews(views);
  return views;
}

void EvalEnv::Render(size_t index, unsigned char* rgb) {
  if (cameras_ && index >= cameras_->size()) {
    throw Error("camera index " + std::to_string(index) + " out of range (" +
                std::to_string(cameras_->size()) + " cameras)");
  }
  const std::vector<sim::CameraView> views = PrepareViews();
  renderer_->Render(env_->data(), views[index], rgb, nullptr);
}

void EvalEnv::Observe(std::span<unsigned char* const> rgb,
                      std::vector<std::vector<ImagePoints>>* points) {
  if (!started()) throw Error("observe before reset: call reset first");
  const std::vector<sim::CameraView> views = PrepareViews();
  if (rgb.size() != views.size()) {
    throw UsageError("EvalEnv::Observe: " + std::to_string(rgb.size()) + " frames for " +
                     std::to_string(views.size()) + " cameras");
  }
  if (points != nullptr) points->assign(views.size(), {});
  // The frames carry the tracked geoms' ids (SampleLastFrame reads them, nothing redrawn).
  renderer_->TrackGeoms(points != nullptr && points_ != nullptr ? points_->tracked_geoms()
                                                                : std::vector<unsigned char>{});
  const mjData* d = env_->data();
  for (size_t i = 0; i < views.size(); ++i) {
    renderer_->Render(d, views[i], rgb[i], nullptr);
    if (points == nullptr || points_ == nullptr || !TracksObjectsIn(cameras_->name(i))) continue;
    (*points)[i] = points_->SampleLastFrame(*renderer_, d, views[i],
                                            camera_config_.cameras[i].skip_erosion, points_rng_);
  }
}

std::vector<TrackedObject> EvalEnv::image_point_objects() const {
  return points_ ? points_->objects() : std::vector<TrackedObject>{};
}

}  // namespace mlspaces::datagen
