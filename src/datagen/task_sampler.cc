#include "mlspaces/datagen/task_sampler.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/datagen/tasks/open_close/sampler.h"
#include "mlspaces/datagen/tasks/pick_and_place/sampler.h"
#include "mlspaces/sim/scene.h"

namespace mlspaces::datagen {
namespace {

std::string SamplerLabel(const std::string& name) {
  return name.empty() ? std::string("task sampler") : "task sampler '" + name + "'";
}

void CheckPose(const std::string& sampler, const char* field, const std::optional<Pose>& pose) {
  if (!pose) throw Error(SamplerLabel(sampler) + " did not set " + field, "", field);
  for (double v : ToArray7(*pose)) {
    if (!std::isfinite(v)) {
      throw Error(SamplerLabel(sampler) + " set " + field + " to a non-finite value", "", field);
    }
  }
  const Quat& q = pose->quat;
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (std::abs(norm - 1.0) > 1e-6) {
    throw Error(SamplerLabel(sampler) + " set " + field +
                    " with a quaternion that is not unit (norm " + std::to_string(norm) + ")",
                "", field);
  }
}

}  // namespace

uint64_t EpisodeSeed(uint64_t run_seed, std::string_view scene_key, int64_t episode) {
  return DeriveSeed(run_seed, {HashString(scene_key), static_cast<uint64_t>(episode)});
}

TaskSampler::TaskSampler(ExperimentConfig config, uint64_t run_seed)
    : config_(std::move(config)), run_seed_(run_seed) {}

Task TaskSampler::SampleTask(Env& env, int64_t episode) {
  const uint64_t seed = EpisodeSeed(run_seed_, env.scene_key(), episode);
  Rng rng(seed);
  episode_ = episode;
  RandomizeScene(env, rng);
  env.Forward();
  TaskDraft draft;
  std::string picked = SelectPickupObject(env, rng);
  if (!picked.empty()) draft.pickup_obj_name = std::move(picked);
  SampleAndPlaceRobot(env, rng, draft);
  env.Forward();

  if (!draft.pickup_obj_name || draft.pickup_obj_name->empty()) {
    throw Error(SamplerLabel(name_) + " did not set pickup_obj_name", "", "pickup_obj_name");
  }
  if (mj_name2id(env.model(), mjOBJ_BODY, draft.pickup_obj_name->c_str()) < 0) {
    throw Error(SamplerLabel(name_) + " set pickup_obj_name to '" + *draft.pickup_obj_name +
                    "', which is not a body of the scene",
                "", "pickup_obj_name");
  }
  CheckPose(name_, "robot_base_pose", draft.robot_base_pose);
  CheckPose(name_, "pickup_obj_start_pose", draft.pickup_obj_start_pose);
  CheckPose(name_, "pickup_obj_goal_pose", draft.pickup_obj_goal_pose);

  Task task;
  task.pickup_obj_name = *draft.pickup_obj_name;
  task.robot_base_pose = *draft.robot_base_pose;
  task.pickup_obj_start_pose = *draft.pickup_obj_start_pose;
  task.pickup_obj_goal_pose = *draft.pickup_obj_goal_pose;
  task.joint = draft.joint;
  task.place = draft.place;
  task.episode = episode;
  task.seed = seed;
  return task;
}

void TaskSampler::RandomizeScene(Env& env, Rng& rng) {
  env.Reset();
  const std::vector<double>& noise = env.robot().home_noise;
  const std::vector<int>& adr = env.arm_qpos_adr();
  mjData* d = env.data();
  const mjModel* m = env.model();
  for (size_t i = 0; i < adr.size() && i < noise.size(); ++i) {
    d->qpos[adr[i]] += rng.Uniform(-noise[i], noise[i]);
    const std::string servo = env.robot().prefix + env.robot().arm_actuators[i];
    if (const int act = mj_name2id(m, mjOBJ_ACTUATOR, servo.c_str()); act >= 0) {
      d->ctrl[act] = d->qpos[adr[i]];
    }
  }
}

std::string TaskSampler::SelectPickupObject(Env& env, Rng& /*rng*/) {
  if (config_.task_config.pickup_obj_name) return *config_.task_config.pickup_obj_name;
  const std::vector<std::string> candidates = CandidateObjects(env);
  if (candidates.empty()) {
    throw Error(SamplerLabel(name_) + ": the scene " + env.scene_key() +
                " has no candidate pickup object (a top-level body with a free joint)");
  }
  const size_t i = static_cast<size_t>(task_counter_++) % candidates.size();
  return candidates[i];
}

std::vector<std::string> TaskSampler::CandidateObjects(const Env& env) {
  const mjModel* m = env.model();
  std::vector<std::string> out;
  for (int b = 1; b < m->nbody; ++b) {
    if (m->body_parentid[b] != 0 || m->body_jntnum[b] != 1) continue;
    if (m->jnt_type[m->body_jntadr[b]] != mjJNT_FREE) continue;
    std::string name = sim::MjName(m, mjOBJ_BODY, b);
    if (name.empty() || name.starts_with(env.robot().prefix)) continue;
    if (name.starts_with("place_receptacle/")) continue;  // pick-and-place receptacles
    out.push_back(std::move(name));
  }
  return out;
}

Env CreateSceneEnv(const ExperimentConfig& config, TaskSampler& sampler,
                   const std::filesystem::path& scene_xml, std::string scene_key) {
  sim::Scene composed = sim::Scene::Load(scene_xml);
  sampler.AddAuxiliaryObjects(composed);
  return Env::Create(std::move(composed),
                     RobotSpecFromConfig(config.robot_config, {}, config.libraries.assets_dir),
                     std::move(scene_key));
}

Pose ComposePlanar(const Pose& pose, double dx, double dy, double yaw) {
  const Mat4 base = ToMat4(Pose{pose.pos, QuatNormalized(pose.quat)});
  Mat4 local = RotZ(yaw);
  local(0, 3) = dx;
  local(1, 3) = dy;
  const Mat4 moved = base * local;
  const double c = std::cos(yaw / 2), s = std::sin(yaw / 2);
  return {Translation(moved), QuatNormalized(QuatMul(pose.quat, {c, 0, 0, s}))};
}

void BlockPickupTaskSampler::SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) {
  const TaskSamplerConfig& cfg = config().task_sampler_config;
  constexpr double kDeg = std::numbers::pi / 180.0;
  auto draw = [&rng](double a) { return rng.Uniform(-std::abs(a), std::abs(a)); };

  const double rx = draw(cfg.robot_base_noise.x);
  const double ry = draw(cfg.robot_base_noise.y);
  const double ryaw = draw(cfg.robot_base_noise.yaw_deg) * kDeg;
  env.SetRobotBasePose(ComposePlanar(env.GetRobotBasePose(), rx, ry, ryaw));
  env.ForwardPosition();
  draft.robot_base_pose = env.GetRobotBasePose();

  if (!draft.pickup_obj_name) {
    throw Error("block_pickup has no pickup object to place", "", "pickup_obj_name");
  }
  const std::string& object = *draft.pickup_obj_name;
  const double ox = draw(cfg.object_noise.x);
  const double oy = draw(cfg.object_noise.y);
  const double oyaw = draw(cfg.object_noise.yaw_deg) * kDeg;
  env.SetBodyPose(object, ComposePlanar(env.GetBodyPose(object), ox, oy, oyaw));
  env.ForwardPosition();
  draft.pickup_obj_start_pose = env.GetBodyPose(object);
  Pose goal = *draft.pickup_obj_start_pose;
  goal.pos[2] += cfg.goal_offset_z;
  draft.pickup_obj_goal_pose = goal;
}

TaskSamplerRegistry TaskSamplerRegistry::WithBuiltins() {
  TaskSamplerRegistry registry;
  registry.Register("block_pickup", [](const ExperimentConfig& config, uint64_t seed) {
    return std::make_unique<BlockPickupTaskSampler>(config, seed);
  });
  RegisterOpenCloseSamplers(registry);
  RegisterPickAndPlaceSamplers(registry);
  return registry;
}

void TaskSamplerRegistry::Register(std::string_view name, TaskSamplerFactory factory) {
  if (name.empty()) throw UsageError("a task sampler needs a non-empty name");
  if (!factory) throw UsageError("task sampler '" + std::string(name) + "' has no factory");
  const std::string key = Lower(name);
  if (auto it = entries_.find(key); it != entries_.end()) {
    throw UsageError("task sampler '" + std::string(name) + "' is already registered (as '" +
                     it->second.name + "')");
  }
  entries_.emplace(key, Entry{std::string(name), std::move(factory)});
}

bool TaskSamplerRegistry::Contains(std::string_view name) const {
  return entries_.contains(Lower(name));
}

std::vector<std::string> TaskSamplerRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& [key, entry] : entries_) out.push_back(entry.name);
  return out;
}

std::unique_ptr<TaskSampler> TaskSamplerRegistry::Create(std::string_view name,
                                                         const ExperimentConfig& config,
                                                         uint64_t run_seed) const {
  const auto it = entries_.find(Lower(name));
  if (it == entries_.end()) {
    std::string valid;
    for (const std::string& n : names()) valid += (valid.empty() ? "" : ", ") + n;
    throw Error("unknown task sampler '" + std::string(name) +
                    "'; registered: " + (valid.empty() ? std::string("(none)") : valid),
                "", "/task_sampler_config/task_sampler_class");
  }
  std::unique_ptr<TaskSampler> sampler = it->second.factory(config, run_seed);
  if (!sampler) throw Error("the factory of task sampler '" + it->second.name + "' returned null");
  sampler->name_ = it->second.name;
  return sampler;
}

std::unique_ptr<TaskSampler> TaskSamplerRegistry::Create(const ExperimentConfig& config,
                                                         uint64_t run_seed) const {
  return Create(config.task_sampler_config.task_sampler_class, config, run_seed);
}

}  // namespace mlspaces::datagen
