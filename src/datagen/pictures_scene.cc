// ScenePicture: a datagen scene as the engine composes it (EvalEnv: scene + robot compiled
// once, the task sampled as a run samples it), from overview views and the configured cameras.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/camera_recorder.h"
#include "mlspaces/datagen/eval_env.h"
#include "mlspaces/datagen/pictures.h"
#include "mlspaces/datagen/task_sampler.h"

namespace mlspaces::datagen {

namespace {

/// The run seed of a request.
uint64_t RunSeed(const ExperimentConfig& config, const SceneRequest& request) {
  return request.seed ? *request.seed : config.seed.value_or(0);
}

}  // namespace

sim::Image ScenePicture(const ExperimentConfig& config, const SceneRequest& request,
                        const sim::PictureOptions& options) {
  return ScenePicture(config, request, options,
                      TaskSamplerRegistry::WithBuiltins().Create(config, RunSeed(config, request)));
}

sim::Image ScenePicture(const ExperimentConfig& config, const SceneRequest& request,
                        const sim::PictureOptions& options, std::unique_ptr<TaskSampler> sampler) {
  if (sampler == nullptr) throw UsageError("scene picture: no task sampler");
  if (request.max_attempts < 1) throw UsageError("scene picture: max_attempts must be >= 1");
  if (request.overview_views < 0) throw UsageError("scene picture: overview_views must be >= 0");
  const uint64_t seed = RunSeed(config, request);
  EvalEnvOptions env_options;
  env_options.render = false;  // this picture makes its own renderer, at the tile size
  env_options.gl_backend = options.backend;
  EvalEnv env(config, std::move(sampler), env_options);
  int64_t episode = request.episode;
  std::string last_reason;
  bool sampled = false;
  for (int attempt = 0; attempt < request.max_attempts && !sampled; ++attempt, ++episode) {
    try {
      env.Reset(seed, request.house, episode);
      sampled = true;
    } catch (const TaskRejected& e) {
      last_reason = e.what();
    }
  }
  if (!sampled) {
    throw Error("house " + std::to_string(request.house) + ": the sampler rejected episodes " +
                std::to_string(request.episode) + ".." + std::to_string(episode - 1) +
                " (last: " + last_reason + ")");
  }
  --episode;  // the one accepted
  const mjModel* m = env.env().model();
  const mjData* d = env.env().data();
  std::vector<sim::CameraView> views;
  std::vector<std::string> labels;
  // Overview: around the midpoint of the robot base and the object, wide enough for both.
  const Task& task = env.task();
  const Vec3& a = task.robot_base_pose.pos;
  const Vec3& b = task.pickup_obj_start_pose.pos;
  const std::array<double, 3> center{(a[0] + b[0]) / 2, (a[1] + b[1]) / 2,
                                     std::max(0.2, (a[2] + b[2]) / 2)};
  const double span = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]));
  const double radius = std::max(0.5, span / 2 + 0.45);
  if (request.overview_views > 0) {
    // The first view from behind the object, towards the robot's left.
    const double az = std::atan2(b[1] - a[1], b[0] - a[0]) * 180 / 3.14159265358979323846 + 45;
    for (const sim::CameraView& v :
         sim::OrbitViews(center, radius, request.overview_views, 35, az)) {
      views.push_back(v);
      labels.push_back(request.overview_views == 1 ? "overview"
                                                   : "overview " + std::to_string(labels.size()));
    }
  }
  const CameraSystem cameras(m, CamerasForRobot(config.camera_config, env.env().robot()));
  for (size_t i = 0; i < cameras.size(); ++i) {
    views.push_back(cameras.View(i, d));
    labels.push_back(cameras.name(i));
  }
  if (views.empty()) throw UsageError("scene picture: no overview views and no cameras");
  sim::PictureOptions o = options;
  o.plain_background = false;  // the scene's own sky and floor
  std::vector<sim::Image> tiles = sim::RenderViews(m, d, views, o);
  const std::string title = "house " + std::to_string(request.house) + ", episode " +
                            std::to_string(episode) + ": " + task.pickup_obj_name;
  return sim::ComposeGrid(tiles, labels, std::min<int>(static_cast<int>(tiles.size()), 3), title);
}

}  // namespace mlspaces::datagen
