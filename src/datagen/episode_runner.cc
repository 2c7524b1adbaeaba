#include "mlspaces/datagen/episode_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string_view>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/core/version.h"
#include "mlspaces/datagen/policy_step.h"
#include "mlspaces/datagen/preflight.h"
#include "mlspaces/datagen/tasks/pick/success.h"
#include "mlspaces/datagen/tasks/task_family.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/scene_metadata.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

std::vector<double> PoseRow(const Pose& pose) {
  const Array7 row = ToArray7(pose);
  return {row.begin(), row.end()};
}

std::vector<double> PoseRow(const Mat4& pose) { return PoseRow(ToPose(pose)); }

// SE(3) log of a rigid transform as [v; w] (the twist that reaches it in unit time).
std::vector<double> Se3Log(const Mat4& t) {
  const Vec3 w = RotationLog(t);
  const Vec3 p = Translation(t);
  const double theta = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  // v = V^-1 p, V^-1 = I - W/2 + c W^2 with W = [w]x.
  auto cross = [](const Vec3& a, const Vec3& b) {
    return Vec3{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  };
  double c = 1.0 / 12.0;
  if (theta > 1e-6) {
    c = (1.0 - theta * std::sin(theta) / (2.0 * (1.0 - std::cos(theta)))) / (theta * theta);
  }
  const Vec3 wp = cross(w, p);
  const Vec3 wwp = cross(w, wp);
  std::vector<double> out(6);
  for (int i = 0; i < 3; ++i) {
    out[i] = p[i] - 0.5 * wp[i] + c * wwp[i];
    out[3 + i] = w[i];
  }
  return out;
}

Outcome OutcomeOfFailure(PlanFailure f) {
  switch (f) {
    case PlanFailure::kNoGrasp:
      return Outcome::kNoGrasp;
    case PlanFailure::kIkFail:
      return Outcome::kIkFail;
    case PlanFailure::kCollision:
      return Outcome::kCollision;
    case PlanFailure::kEmptyGrasp:
      return Outcome::kGraspSlip;
    case PlanFailure::kNone:
      break;
  }
  return Outcome::kGraspSlip;
}

// The licences of the assets a scene's metadata names (asset_id of each object that a library
// holds), each UID once, sorted: recorded in every episode's provenance (role "scene").
std::vector<AssetProvenance> SceneAssetLicenses(const Json& metadata, const Registry& registry) {
  std::map<std::string, AssetProvenance> by_uid;
  const auto objects = metadata.is_object() ? metadata.find("objects") : metadata.end();
  if (objects == metadata.end() || !objects->is_object()) return {};
  for (const auto& [body, entry] : objects->items()) {
    const auto id = entry.is_object() ? entry.find("asset_id") : entry.end();
    if (id == entry.end() || !id->is_string() || by_uid.contains(id->get<std::string>())) continue;
    const std::string uid = id->get<std::string>();
    const std::optional<AssetLocation> where = registry.Locate(uid);
    const std::shared_ptr<const Annotation> annotation = registry.GetAnnotation(uid);
    if (!where && !annotation) continue;  // walls, rooms: no asset of any library
    const std::string library = where ? where->library : annotation->library;
    by_uid[uid] = {uid, library, AssetLicenseName(library, annotation.get()), "scene"};
  }
  std::vector<AssetProvenance> out;
  out.reserve(by_uid.size());
  for (auto& [uid, asset] : by_uid) out.push_back(std::move(asset));
  return out;
}

/// Why `policy` refuses an asset with licence `license` (SPDX-style), or "".
std::string LicenseRefusal(LicensePolicy policy, const std::string& uid,
                           const std::string& license) {
  if (policy != LicensePolicy::kCommercialSafe) return {};
  const bool nc =
      license == "CC-BY-NC-4.0" || license == "CC-BY-NC-SA-4.0" || IsNonCommercialLicense(license);
  if (!nc) return {};
  return "licence policy commercial_safe: asset " + uid + " is " + license + " (non-commercial)";
}

}  // namespace

struct EpisodeRunner::Impl {
  sim::DataPtr scratch;  // forward kinematics of commanded joints
  std::vector<int> object_geoms;
  // The licence policy, the scene's assets and why the policy refuses the scene ("" = not).
  LicensePolicy license_policy = LicensePolicy::kAll;
  std::vector<AssetProvenance> scene_assets;
  std::string scene_refusal;
};

EpisodeRunner::EpisodeRunner(Env& env, TaskSampler& sampler, const Registry& registry,
                             const ExperimentConfig& config, EpisodeRunnerOptions options)
    : env_(env),
      sampler_(sampler),
      registry_(registry),
      config_(config),
      options_(std::move(options)),
      robot_(env.model(), env.robot()),
      planner_owned_(TaskFamilyOf(config.task_type).make_planner(env, robot_, config)),
      planner_(*planner_owned_),
      impl_(std::make_unique<Impl>()) {
  substeps_ = PolicySubsteps(config);
  CheckSimTimestep(env.model(), config, env.scene_key());
  impl_->scratch = sim::MakeData(env.model());
  impl_->license_policy = ResolveLicensePolicy(config.license_policy);
  impl_->scene_assets = SceneAssetLicenses(env.metadata(), registry);
  for (const AssetProvenance& a : impl_->scene_assets) {
    if (std::string why = LicenseRefusal(impl_->license_policy, a.uid, a.license); !why.empty()) {
      impl_->scene_refusal = "the scene " + env.scene_key() + " is refused: " + why;
      break;
    }
  }
  const TaskConfig& task = config.task_config;
  const CameraSystemConfig cameras = CamerasForRobot(config.camera_config, env.robot());
  if (options_.record && !options_.video_dir.empty() && task.enable_rendering && task.use_sensors &&
      !cameras.cameras.empty()) {
    cameras_ =
        std::make_unique<CameraRecorder>(env.model(), cameras, config.fps(), options_.gl_backend);
  }
}

EpisodeRunner::~EpisodeRunner() = default;

struct EpisodeRunner::Episode {
  EpisodeResult result;
  AttemptRecord& attempt = result.attempt;
  int64_t index = 0;
  /// The sampled task, as its family plans, judges and records it.
  std::unique_ptr<TaskEpisode> task;
  // The object's grasps, their asset and the grasp-library filter.
  std::string uid;
  std::shared_ptr<const Annotation> annotation;
  GraspSet grasps;
  std::vector<std::string> filter;
  // The rollout.
  EpisodeRecord rec;
  Mat4 grasp_world;
  double start_z = 0;
  /// The scene's free objects (env_states/actors, always empty in the original).
  std::vector<std::pair<std::string, int>> actors;
  Mat4 prev_tcp;
  std::vector<double> prev_arm_qpos;
  PickSuccess verdict;
  int64_t step = 0;
  bool terminated = false, truncated = false;
};

EpisodeResult EpisodeRunner::Run(int64_t episode) {
  Episode e;
  e.index = episode;
  AttemptRecord& attempt = e.attempt;
  attempt.scene = options_.scene_name;
  attempt.episode = episode;
  attempt.seed = EpisodeSeed(sampler_.run_seed(), env_.scene_key(), episode);
  attempt.extra = Json::object();
  if (!impl_->scene_refusal.empty()) {  // before anything is simulated
    attempt.outcome = Outcome::kSamplerReject;
    attempt.message = impl_->scene_refusal;
    return std::move(e.result);
  }
  if (!SampleTask(e) || !LoadGrasps(e) || !Plan(e)) return std::move(e.result);
  BeginRecording(e);
  Rollout(e);
  Judge(e);
  if (options_.record) FinishRecord(e);
  return std::move(e.result);
}

bool EpisodeRunner::SampleTask(Episode& e) {
  const auto t0 = Clock::now();
  Task task;
  try {
    task = sampler_.SampleTask(env_, e.index);
  } catch (const TaskRejected& error) {
    e.attempt.AddTiming("sample", Since(t0));
    e.attempt.outcome = Outcome::kSamplerReject;
    e.attempt.message = error.what();
    return false;
  }
  e.attempt.AddTiming("sample", Since(t0));
  e.task =
      TaskFamilyOf(config_.task_type).make_episode(env_, config_, std::move(task), sampler_.name());
  e.task->AddSampleInfo(e.attempt.extra);
  return true;
}

// The object's grasps (missing ones are a "no grasp" attempt, as the original's candidate
// rejection, and an input error: preflight.h).
bool EpisodeRunner::LoadGrasps(Episode& e) {
  const auto t0 = Clock::now();
  e.filter = config_.policy_config.grasp_libraries ? *config_.policy_config.grasp_libraries
                                                   : std::vector<std::string>{};
  const fs::path metadata_file = SceneMetadataFileFor(env_.scene().composer().path());
  try {
    e.uid = PickupAssetId(env_.metadata(), metadata_file, e.task->task().pickup_obj_name);
    e.annotation = registry_.GetAnnotation(e.uid);
    const std::optional<AssetLocation> where = registry_.Locate(e.uid);
    const std::string license =
        AssetLicenseName(where ? where->library : std::string(), e.annotation.get());
    if (std::string why = LicenseRefusal(impl_->license_policy, e.uid, license); !why.empty()) {
      e.attempt.AddTiming("grasps", Since(t0));
      e.attempt.outcome = Outcome::kSamplerReject;
      e.attempt.message = "the pickup object is refused: " + why;
      return false;
    }
    e.grasps = e.task->LoadGrasps(registry_, e.uid, metadata_file, e.filter);
  } catch (const Error& error) {
    e.attempt.AddTiming("grasps", Since(t0));
    e.attempt.outcome = Outcome::kNoGrasp;
    e.attempt.message = error.what();
    e.result.input_error = error;
    return false;
  }
  e.attempt.AddTiming("grasps", Since(t0));
  return true;
}

bool EpisodeRunner::Plan(Episode& e) {
  const auto t0 = Clock::now();
  const PlanFailure planned = e.task->Plan(planner_, env_.data(), e.grasps.poses);
  AttemptRecord& attempt = e.attempt;
  attempt.AddTiming("plan", Since(t0));
  attempt.extra["num_grasps"] = e.grasps.poses.size();
  attempt.extra["num_collision_free"] = planner_.stats().num_collision_free;
  if (planned != PlanFailure::kNone) {
    attempt.outcome = OutcomeOfFailure(planned);
    attempt.message = planner_.message();
    return false;
  }
  attempt.extra["grasp_index"] = *planner_.grasp_index();
  e.task->AddPlanInfo(planner_, attempt.extra);
  return true;
}

void EpisodeRunner::BeginRecording(Episode& e) {
  const mjModel* m = env_.model();
  e.grasp_world = planner_.grasp_pose();
  e.start_z = e.task->task().pickup_obj_start_pose.pos[2];
  for (int b = 1; b < m->nbody; ++b) {
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    if (name == nullptr || m->body_parentid[b] != 0 || m->body_jntnum[b] != 1) continue;
    const int j = m->body_jntadr[b];
    if (m->jnt_type[j] != mjJNT_FREE) continue;
    if (std::string_view(name).rfind(env_.robot().prefix, 0) == 0) continue;
    e.actors.emplace_back(name, j);
  }
  if (options_.record) {
    EpisodeRecord& rec = e.rec;
    rec.extra["robot_base_pose"] = Series(DType::kFloat32, {7});
    rec.extra["obj_start"] = Series(DType::kFloat32, {7});
    rec.extra["obj_end"] = Series(DType::kFloat32, {7});
    rec.extra["tcp_pose"] = Series(DType::kFloat32, {7});
    rec.extra["grasp_pose"] = Series(DType::kFloat32, {7});
    rec.extra["policy_phase"] = Series(DType::kInt64, {});
    rec.extra["policy_num_retries"] = Series(DType::kInt64, {});
    rec.extra_json["task_info"].max_len = 4000;
    rec.extra_json["grasp_state_pickup_obj"].max_len = 2000;
    e.task->DeclareSeries(rec);
    rec.env_states["articulations/" + env_.robot().articulation_name] =
        Series(DType::kFloat32, {env_.robot().articulation_width});
    for (const auto& [name, joint] : e.actors) {
      rec.env_states["actors/" + name] = Series(DType::kFloat32, {13});
    }
  }
  e.prev_tcp = robot_.TcpPose(env_.data());
  e.prev_arm_qpos = robot_.ArmQpos(env_.data());
}

Mat4 EpisodeRunner::CommandedTcp(const std::vector<double>& q) {
  const mjModel* m = env_.model();
  const mjData* d = env_.data();
  mjData* scratch = impl_->scratch.get();
  std::copy_n(d->qpos, m->nq, scratch->qpos);
  std::copy_n(d->mocap_pos, 3 * m->nmocap, scratch->mocap_pos);
  std::copy_n(d->mocap_quat, 4 * m->nmocap, scratch->mocap_quat);
  for (size_t i = 0; i < robot_.num_arm(); ++i) scratch->qpos[robot_.arm_qpos_adr()[i]] = q[i];
  mj_kinematics(m, scratch);
  return robot_.TcpPose(scratch);
}

void EpisodeRunner::Observe(Episode& e, const PlannerAction* action) {
  const mjModel* m = env_.model();
  const mjData* d = env_.data();
  const Task& task = e.task->task();
  const int object = e.task->object();
  e.verdict = EvaluatePickSuccess(m, d, object, e.start_z, env_.robot().prefix,
                                  config_.task_config.succ_pos_threshold);
  e.task->Judge(d, e.verdict);
  if (!options_.record) return;
  EpisodeRecord& rec = e.rec;
  const size_t artic_width = env_.robot().articulation_width;
  const std::vector<double> arm_q = robot_.ArmQpos(d), grip_q = robot_.GripperQpos(d);
  const std::vector<double> arm_v = robot_.ArmQvel(d), grip_v = robot_.GripperQvel(d);
  rec.qpos.push_back({{"arm", arm_q}, {"base", {}}, {"gripper", grip_q}});
  rec.qvel.push_back({{"arm", arm_v}, {"base", {}}, {"gripper", grip_v}});
  const Mat4 base = robot_.BasePose(d);
  const Mat4 base_inv = InverseRigid(base);
  rec.extra["robot_base_pose"].Append(PoseRow(env_.GetRobotBasePose()));
  rec.extra["obj_start"].Append(PoseRow(task.pickup_obj_start_pose));
  rec.extra["obj_end"].Append(PoseRow(task.pickup_obj_goal_pose));
  rec.extra["tcp_pose"].Append(PoseRow(base_inv * robot_.TcpPose(d)));
  rec.extra["grasp_pose"].Append(PoseRow(e.grasp_world));
  rec.extra["policy_phase"].AppendInts({static_cast<int64_t>(planner_.phase())});
  rec.extra["policy_num_retries"].AppendInts({planner_.retries()});
  std::vector<double> panda(artic_width, 0.0);
  size_t k = 0;
  for (double v : arm_q)
    if (k < artic_width) panda[k++] = v;
  for (double v : grip_q)
    if (k < artic_width) panda[k++] = v;
  for (double v : arm_v)
    if (k < artic_width) panda[k++] = v;
  for (double v : grip_v)
    if (k < artic_width) panda[k++] = v;
  rec.env_states["articulations/" + env_.robot().articulation_name].Append(panda);
  for (const auto& [name, joint] : e.actors) {
    // Free-joint pose (xyz, quat wxyz) and velocity (linear, angular): 13 values.
    std::vector<double> row(13);
    std::copy_n(d->qpos + m->jnt_qposadr[joint], 7, row.begin());
    std::copy_n(d->qvel + m->jnt_dofadr[joint], 6, row.begin() + 7);
    rec.env_states["actors/" + name].Append(row);
  }

  e.task->Record(rec, d, e.step, e.verdict);
  // Grasp state: contacts of the object with gripper geoms and with anything else.
  bool touching = false, other = false;
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    const int b1 = m->geom_bodyid[con.geom1], b2 = m->geom_bodyid[con.geom2];
    auto in_object = [&](int b) {
      for (; b > 0; b = m->body_parentid[b])
        if (b == object) return true;
      return false;
    };
    const bool o1 = in_object(b1), o2 = in_object(b2);
    if (o1 == o2) continue;
    const int g = o1 ? con.geom2 : con.geom1;
    if (robot_.IsGripperGeom(g))
      touching = true;
    else
      other = true;
  }
  rec.extra_json["grasp_state_pickup_obj"].steps.push_back(
      Json{{"gripper", Json{{"touching", touching}, {"held", touching && !other}}}});

  RecordActions(e, action, base_inv);
  rec.rewards.push_back(static_cast<float>(e.verdict.reward));
  rec.success.push_back(e.verdict.success);
  rec.terminated.push_back(e.terminated);
  rec.truncated.push_back(e.truncated);
  e.prev_tcp = robot_.TcpPose(d);
  e.prev_arm_qpos = arm_q;
}

void EpisodeRunner::RecordActions(Episode& e, const PlannerAction* action, const Mat4& base_inv) {
  const mjData* d = env_.data();
  const size_t n_arm = robot_.num_arm();
  const size_t n_grip = robot_.num_gripper();
  const bool terminal = action != nullptr && action->done;
  auto& acts = e.rec.actions;
  if (action == nullptr) {
    // Observation 0: a dummy command, the servo targets after reset, zero motion.
    const std::vector<double> targets = robot_.ArmTargets(d);
    const Mat4 cmd_tcp = CommandedTcp(targets);
    acts["commanded_action"].push_back({});
    acts["joint_pos"].push_back({{"arm", targets}, {"gripper", {robot_.GripperCtrl(d)}}});
    acts["joint_pos_rel"].push_back({{"arm", std::vector<double>(n_arm, 0.0)},
                                     {"base", {}},
                                     {"gripper", std::vector<double>(n_grip, 0.0)}});
    acts["ee_twist"].push_back(
        {{"arm", std::vector<double>(6, 0.0)}, {"gripper", std::vector<double>(6, 0.0)}});
    const std::vector<double> ee = PoseRow(base_inv * cmd_tcp);
    acts["ee_pose"].push_back({{"arm", ee}, {"base", {0, 0, 0, 1, 0, 0, 0}}, {"gripper", ee}});
    return;
  }
  // The policy's action as the original stores it: in its action dtype, the arm as absolute
  // targets or, in joint_rel_position mode, as the change from the joints at the previous
  // observation.
  std::vector<double> arm = action->arm;
  if (config_.robot_config.command_mode.arm == ArmCommandMode::kJointRelPosition) {
    for (size_t i = 0; i < n_arm; ++i) arm[i] -= e.prev_arm_qpos[i];
  }
  double gripper = action->gripper;
  if (config_.task_config.action_dtype == ActionDtype::kFloat32) {
    for (double& v : arm) v = static_cast<float>(v);
    gripper = static_cast<float>(gripper);
  }
  acts["commanded_action"].push_back({{"arm", arm}, {"base", {}}, {"gripper", {gripper}}});
  if (terminal) {
    for (const char* name : {"joint_pos", "joint_pos_rel", "ee_twist", "ee_pose"}) {
      acts[name].push_back({});
    }
    return;
  }
  // CommandedTcp() reads the joints of the previous state, restored below; the arm is
  // replaced.
  const Mat4 cmd_tcp = CommandedTcp(action->arm);
  std::vector<double> rel(n_arm);
  for (size_t i = 0; i < n_arm; ++i) rel[i] = action->arm[i] - e.prev_arm_qpos[i];
  acts["joint_pos"].push_back({{"arm", action->arm}, {"gripper", {action->gripper}}});
  acts["joint_pos_rel"].push_back({{"arm", rel}});
  const std::vector<double> twist = Se3Log(InverseRigid(e.prev_tcp) * cmd_tcp);
  acts["ee_twist"].push_back({{"arm", twist}, {"gripper", twist}});
  const std::vector<double> ee = PoseRow(base_inv * cmd_tcp);
  acts["ee_pose"].push_back({{"arm", ee}, {"base", {0, 0, 0, 1, 0, 0, 0}}, {"gripper", ee}});
}

void EpisodeRunner::Rollout(Episode& e) {
  const mjModel* m = env_.model();
  mjData* d = env_.data();
  AttemptRecord& attempt = e.attempt;
  Rng noise_rng = EpisodeNoiseRng(attempt.seed);

  // Cameras: one frame per observation; an exception drops the episode's videos.
  struct AbortVideos {
    CameraRecorder* c;
    ~AbortVideos() {
      if (c != nullptr) c->Abort();
    }
  } abort_videos{cameras_.get()};
  const double render0 = cameras_ ? cameras_->render_seconds() : 0;
  const double encode0 = cameras_ ? cameras_->encode_seconds() : 0;
  const double points0 = cameras_ ? cameras_->points_seconds() : 0;
  std::map<std::string, Series>* points = options_.record ? &e.rec.extra : nullptr;
  if (cameras_) {
    const RobotSpec& robot = env_.robot();
    cameras_->Begin(
        options_.video_dir, e.index,
        TaskObjects(m, e.task->task(), config_.task_config, robot.prefix + robot.gripper_body),
        attempt.seed);
  }

  double t_policy = 0, t_physics = 0, t_observe = 0;
  auto t_obs = Clock::now();
  Observe(e, nullptr);
  if (cameras_) cameras_->Capture(d, points);
  t_observe += Since(t_obs);
  const ActionNoiseConfig& noise = config_.robot_config.action_noise_config;
  while (!e.terminated && !e.truncated) {
    auto tp = Clock::now();
    const PlannerAction action = planner_.Act(d);
    // The controller: noisy arm targets (un-noised ones are recorded), gripper ctrl.
    const std::vector<double> target =
        ControllerArmTargets(robot_, d, action.arm, noise, noise_rng);
    t_policy += Since(tp);
    auto ts = Clock::now();
    StepPhysics(robot_, m, d, target, action.gripper, substeps_, [&] {
      if (options_.on_step) options_.on_step(m, d, e.step);
    });
    t_physics += Since(ts);
    e.result.physics_steps += substeps_;
    ++e.step;
    e.terminated = action.done;
    e.truncated = e.step >= config_.task_horizon;
    t_obs = Clock::now();
    Observe(e, &action);
    if (cameras_) cameras_->Capture(d, points);
    t_observe += Since(t_obs);
    if (config_.end_on_success && e.verdict.success && !e.terminated) {
      e.terminated = true;
      if (options_.record) e.rec.terminated.back() = true;
    }
  }
  e.result.policy_steps = e.step;
  attempt.AddTiming("policy", t_policy);
  attempt.AddTiming("physics", t_physics);
  if (cameras_) {
    e.rec.cameras = cameras_->End();
    const double render = cameras_->render_seconds() - render0;
    const double encode = cameras_->encode_seconds() - encode0;
    const double image_points = cameras_->points_seconds() - points0;
    attempt.AddTiming("observe", std::max(0.0, t_observe - render - encode - image_points));
    attempt.AddTiming("render", render);
    attempt.AddTiming("encode", encode);
    if (image_points > 0) attempt.AddTiming("points", image_points);
  } else {
    attempt.AddTiming("observe", t_observe);
  }
  attempt.extra["policy_steps"] = e.step;
  attempt.extra["retries"] = planner_.retries();
  attempt.extra["lift"] = e.verdict.lift;
  e.task->AddRolloutInfo(attempt.extra, e.step);
}

void EpisodeRunner::Judge(Episode& e) {
  AttemptRecord& attempt = e.attempt;
  const PickSuccess& verdict = e.verdict;
  e.result.success = verdict.success;
  if (verdict.success) {
    attempt.outcome = Outcome::kSuccess;
  } else if (planner_.gave_up()) {
    attempt.outcome = OutcomeOfFailure(planner_.failure());
    attempt.message = std::string(PlanFailureName(planner_.failure())) + ": " + planner_.message() +
                      " (after " + std::to_string(planner_.retries()) + " retries)";
  } else if (e.truncated && !e.terminated) {
    attempt.outcome = Outcome::kTimeout;
    attempt.message =
        "the horizon of " + std::to_string(config_.task_horizon) + " policy steps ran out";
  } else {
    attempt.outcome = Outcome::kGraspSlip;
    attempt.message = e.task->FailureMessage(verdict, e.step);
  }
}

void EpisodeRunner::FinishRecord(Episode& e) {
  EpisodeRecord& rec = e.rec;
  const Task& task = e.task->task();
  const std::string& uid = e.uid;
  EpisodeMetadata& meta = rec.meta;
  if (options_.config_hash.empty()) options_.config_hash = DataConfigHashHex(config_);
  meta.config_hash = options_.config_hash;
  meta.seed = e.attempt.seed;
  meta.scene = options_.scene_name;
  meta.source_episode = e.index;
  const std::string expr = Referral(task.pickup_obj_name, e.annotation.get());
  meta.task_description = e.task->Description(registry_, expr);
  const std::optional<AssetLocation> where = registry_.Locate(uid);
  const std::string library = where ? where->library : std::string("unknown");
  meta.assets.push_back(
      {uid, library, AssetLicenseName(library, e.annotation.get()), "pickup_obj"});
  for (const AssetProvenance& a : impl_->scene_assets) {
    if (a.uid != uid) meta.assets.push_back(a);
  }
  meta.license_policy = std::string(LicensePolicyName(impl_->license_policy));
  meta.robot = env_.robot().name;
  meta.robot_description_hash = env_.robot().description_hash;
  meta.mujoco_version = mj_versionString();
  meta.mlspaces_version = std::string(Version());
  // Only what is the same on every machine: the grasp file relative to its library.
  std::string grasp_library, grasp_file = e.grasps.source.filename().string();
  if (const auto found = registry_.FindGraspFile({uid, "", e.filter})) {
    grasp_library = found->library;
    if (const GraspLibraryInfo* lib = registry_.FindGraspLibrary(found->library)) {
      grasp_file = found->path.lexically_relative(lib->dir).generic_string();
    }
  }
  // The attempt as journaled, minus its timings (which differ run to run): a resumed run
  // restores a journal line lost in a crash from it.
  Json attempt_json = e.attempt.ToJson();
  attempt_json["timings"] = Json::object();
  meta.extra = Json{{"scene_key", env_.scene_key()},
                    {"grasp_library", grasp_library},
                    {"grasp_file", grasp_file},
                    {"attempt", attempt_json}};
  rec.obs_scene = Json{
      {"task_type", std::string(EnumName(config_.task_type))},
      {"task_description", meta.task_description},
      {"policy_dt_ms", config_.policy_dt_ms},
      {"referral_expressions", Json{{"pickup_obj_name", Json::array({Json::array({expr, 1.0})})}}},
      {"policy_phases", PolicyPhaseMap()},
      {"frozen_config", Json{{"pickup_obj_name", task.pickup_obj_name},
                             {"robot_base_pose", ToArray7(task.robot_base_pose)},
                             {"pickup_obj_start_pose", ToArray7(task.pickup_obj_start_pose)},
                             {"pickup_obj_goal_pose", ToArray7(task.pickup_obj_goal_pose)},
                             {"config_hash", meta.config_hash}}},
      {"text", std::string(EnumName(config_.task_type)) + " " + task.pickup_obj_name},
      {"object_name", task.pickup_obj_name}};
  e.task->AddToObsScene(registry_, expr, rec.obs_scene);
  e.result.record = std::move(rec);
}

}  // namespace mlspaces::datagen
