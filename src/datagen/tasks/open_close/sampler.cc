// The open / close task sampler (tasks/open_close/sampler.h).
#include "mlspaces/datagen/tasks/open_close/sampler.h"

#include <cmath>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/preflight.h"
#include "mlspaces/robots/ik.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {
namespace {

// The metadata entry objects.<body> (null when absent).
const Json* ObjectEntry(const Json& metadata, const std::string& body) {
  if (!metadata.is_object()) return nullptr;
  const auto objects = metadata.find("objects");
  if (objects == metadata.end() || !objects->is_object()) return nullptr;
  const auto entry = objects->find(body);
  if (entry == objects->end() || !entry->is_object()) return nullptr;
  return &*entry;
}

// The clearance the robot must keep from the joint body at the start; the hand is drawn back
// toward the base kBackStep at a time, up to kMaxBack, to get it.
constexpr double kStartClearance = 0.02;
constexpr double kBackStep = 0.01;
constexpr double kMaxBack = 0.15;

// True when a collision geom of the robot (the subtree of `robot_root`) is within `margin`
// of one of the joint body's subtree (`joint_body`).
bool RobotNear(const mjModel* m, const mjData* d, int robot_root, int joint_body, double margin) {
  const std::vector<int> target = sim::CollisionGeoms(m, joint_body);
  for (int a : sim::CollisionGeoms(m, robot_root)) {
    for (int b : target) {
      if (mj_geomDistance(m, d, a, b, margin, nullptr) < margin) return true;
    }
  }
  return false;
}

// Moves the arm (IK from its current angles) so that the TCP is drawn back horizontally
// toward the robot base, in steps, until the robot is kStartClearance clear of the joint
// body. Returns whether it got clear (the arm is left at the last solution tried).
bool DrawHandBack(Env& env, int robot_root, int joint_body) {
  const mjModel* m = env.model();
  mjData* d = env.data();
  const RobotSpec& robot = env.robot();
  std::vector<std::string> joints;
  for (const std::string& j : robot.arm_joints) joints.push_back(robot.prefix + j);
  robots::IkOptions options;
  options.restarts = 0;
  robots::IkSolver ik(m, robot.prefix + robot.tcp_site, joints, {}, options);
  ik.SyncState(d);
  const std::vector<int>& adr = env.arm_qpos_adr();
  std::vector<double> q;
  q.reserve(adr.size());
  for (int a : adr) q.push_back(d->qpos[a]);
  const Mat4 tcp = ik.Forward(q);
  const Pose base = env.GetRobotBasePose();
  double dx = base.pos[0] - tcp(0, 3), dy = base.pos[1] - tcp(1, 3);
  const double norm = std::hypot(dx, dy);
  if (norm < 1e-6) return false;
  for (double back = kBackStep; back <= kMaxBack + 1e-9; back += kBackStep) {
    Mat4 target = tcp;
    target(0, 3) += back * dx / norm;
    target(1, 3) += back * dy / norm;
    const robots::IkResult r = ik.Solve(target, q);
    if (!r.success) continue;
    q = r.q;
    for (size_t i = 0; i < adr.size(); ++i) {
      d->qpos[adr[i]] = q[i];
      // The servo holds the new angle (as TaskSampler::RandomizeScene does for the noise).
      const std::string servo = robot.prefix + robot.arm_actuators[i];
      if (const int act = mj_name2id(m, mjOBJ_ACTUATOR, servo.c_str()); act >= 0) {
        d->ctrl[act] = q[i];
      }
    }
    env.ForwardPosition();
    if (!RobotNear(m, d, robot_root, joint_body, kStartClearance)) return true;
  }
  return false;
}

std::string MetadataFile(const Env& env) {
  return SceneMetadataFileFor(env.scene().composer().path()).string();
}

}  // namespace

bool IsOpenCloseTask(TaskType type) { return type == TaskType::kOpen || type == TaskType::kClose; }

std::vector<ArticulatedJoint> ArticulatedJoints(const Env& env, const std::string& object_body) {
  const mjModel* m = env.model();
  const int root = mj_name2id(m, mjOBJ_BODY, object_body.c_str());
  std::vector<ArticulatedJoint> out;
  if (root <= 0) return out;  // no such body, or the world (no object)
  const Json* entry = ObjectEntry(env.metadata(), object_body);
  const Json* name_map = nullptr;
  if (entry != nullptr) {
    const auto nm = entry->find("name_map");
    if (nm != entry->end() && nm->is_object()) {
      const auto joints = nm->find("joints");
      if (joints != nm->end() && joints->is_object()) name_map = &*joints;
    }
  }
  int index = 0;
  for (int j = 0; j < m->njnt; ++j) {
    if (!sim::InSubtree(m, m->jnt_bodyid[j], root)) continue;
    const int type = m->jnt_type[j];
    if (type == mjJNT_FREE || type == mjJNT_BALL) continue;
    const int this_index = index++;
    const double lo = m->jnt_range[2 * j], hi = m->jnt_range[2 * j + 1];
    if (!m->jnt_limited[j] || !(hi > lo)) continue;  // zero range: nothing to open
    ArticulatedJoint a;
    a.joint_id = j;
    a.index = this_index;
    a.joint.name = sim::MjName(m, mjOBJ_JOINT, j);
    a.joint.asset_joint = a.joint.name;
    if (name_map != nullptr) {
      const auto it = name_map->find(a.joint.name);
      if (it != name_map->end() && it->is_string()) a.joint.asset_joint = it->get<std::string>();
    }
    a.joint.range_lo = lo;
    a.joint.range_hi = hi;
    // Closed = the limit nearest 0; the original assumes one limit is 0 (spec A.8 item 2).
    const bool lo_closed = std::abs(lo) <= std::abs(hi);
    a.joint.closed = lo_closed ? lo : hi;
    a.joint.open = lo_closed ? hi : lo;
    if (a.joint.name.empty()) continue;
    out.push_back(std::move(a));
  }
  return out;
}

OpenTaskSampler::OpenTaskSampler(const ExperimentConfig& config, uint64_t run_seed)
    : TaskSampler(config, run_seed),
      registry_(std::make_unique<Registry>(Registry::Options{config.libraries.assets_dir})) {
  config.libraries.ApplyTo(*registry_);
}

OpenTaskSampler::~OpenTaskSampler() = default;

std::vector<ArticulatedJoint> OpenTaskSampler::UsableJoints(const Env& env,
                                                            const std::string& body) {
  const Json* entry = ObjectEntry(env.metadata(), body);
  if (entry == nullptr) return {};
  const auto id = entry->find("asset_id");
  if (id == entry->end() || !id->is_string()) return {};
  const std::string uid = id->get<std::string>();
  const std::vector<std::string> filter = config().policy_config.grasp_libraries
                                              ? *config().policy_config.grasp_libraries
                                              : std::vector<std::string>{};
  std::vector<ArticulatedJoint> out;
  for (ArticulatedJoint& a : ArticulatedJoints(env, body)) {
    if (registry_->FindGraspFile({uid, a.joint.asset_joint, filter})) out.push_back(std::move(a));
  }
  return out;
}

std::string OpenTaskSampler::SelectPickupObject(Env& env, Rng& rng) {
  const std::string file = MetadataFile(env);
  if (const std::optional<std::string>& preset = config().task_config.pickup_obj_name) {
    if (UsableJoints(env, *preset).empty()) {
      throw Error("articulated object " + *preset +
                      " has no hinge or slide joint with a joint-grasp file (scene " +
                      env.scene_key() + ")",
                  file, "objects." + *preset + ".asset_id");
    }
    return *preset;
  }
  std::vector<std::string> candidates;
  const Json& metadata = env.metadata();
  const auto objects = metadata.is_object() ? metadata.find("objects") : metadata.end();
  if (objects != metadata.end() && objects->is_object()) {
    for (const auto& [body, entry] : objects->items()) {
      if (!UsableJoints(env, body).empty()) candidates.push_back(body);
    }
  }
  if (candidates.empty()) {
    throw Error("the scene " + env.scene_key() +
                    " has no articulated object with a joint-grasp file (a body with hinge or "
                    "slide joints whose asset's joints have grasps)",
                file, "objects");
  }
  return candidates[rng.UniformInt(candidates.size())];
}

void OpenTaskSampler::SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) {
  const ExperimentConfig& cfg = config();
  const std::string& object = *draft.pickup_obj_name;
  std::vector<ArticulatedJoint> joints = UsableJoints(env, object);
  if (const std::optional<std::string>& preset = cfg.task_config.joint_name) {
    std::vector<ArticulatedJoint> kept;
    for (ArticulatedJoint& a : joints) {
      if (a.joint.name == *preset) kept.push_back(std::move(a));
    }
    if (kept.empty()) {
      throw Error("task_config.joint_name '" + *preset + "' is no hinge or slide joint of " +
                      object + " with a joint-grasp file",
                  MetadataFile(env), "task_config.joint_name");
    }
    joints = std::move(kept);
  }
  if (joints.empty()) {
    throw Error("articulated object " + object + " has no joint with a joint-grasp file",
                MetadataFile(env), "objects." + object + ".asset_id");
  }
  ArticulatedJoint chosen = joints[rng.UniformInt(joints.size())];
  const double p = cfg.task_sampler_config.target_initial_state_open_percentage.value_or(
      cfg.task_type == TaskType::kClose ? 0.5 : 0.0);
  TaskJoint& joint = chosen.joint;
  joint.start = joint.closed + p * (joint.open - joint.closed);
  mjData* d = env.data();
  const mjModel* m = env.model();
  d->qpos[m->jnt_qposadr[chosen.joint_id]] = joint.start;
  d->qvel[m->jnt_dofadr[chosen.joint_id]] = 0;

  // The robot base: block_pickup's noise on the scene's pose.
  constexpr double kDeg = std::numbers::pi / 180.0;
  auto draw = [&rng](double a) { return rng.Uniform(-std::abs(a), std::abs(a)); };
  const PlanarNoise& noise = cfg.task_sampler_config.robot_base_noise;
  const double rx = draw(noise.x);
  const double ry = draw(noise.y);
  const double ryaw = draw(noise.yaw_deg) * kDeg;
  env.SetRobotBasePose(ComposePlanar(env.GetRobotBasePose(), rx, ry, ryaw));
  env.ForwardPosition();
  // A robot within kStartClearance of the joint body (a door opened toward it can reach
  // into its hand at home) starts with its hand drawn back toward the base instead.
  const RobotSpec& robot = env.robot();
  const int robot_root = mj_name2id(m, mjOBJ_BODY, (robot.prefix + robot.base_body).c_str());
  const int joint_body = m->jnt_bodyid[chosen.joint_id];
  if (robot_root >= 0 && RobotNear(m, d, robot_root, joint_body, kStartClearance) &&
      !DrawHandBack(env, robot_root, joint_body)) {
    throw TaskRejected("the robot starts within " + std::to_string(kStartClearance) + " m of " +
                       joint.name + "'s body, and drawing its hand back " +
                       std::to_string(kMaxBack) + " m does not clear it");
  }
  draft.robot_base_pose = env.GetRobotBasePose();
  draft.pickup_obj_start_pose = env.GetBodyPose(object);
  draft.pickup_obj_goal_pose = draft.pickup_obj_start_pose;
  draft.joint = joint;
}

void RegisterOpenCloseSamplers(TaskSamplerRegistry& registry) {
  registry.Register("OpenTaskSampler", [](const ExperimentConfig& config, uint64_t seed) {
    return std::make_unique<OpenTaskSampler>(config, seed);
  });
}

}  // namespace mlspaces::datagen
