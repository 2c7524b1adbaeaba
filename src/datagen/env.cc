#include "mlspaces/datagen/env.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/library/assets_dir.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::datagen {
namespace {

int NameToId(const mjModel* m, mjtObj type, const std::string& name) {
  return mj_name2id(m, type, name.c_str());
}

// The free joint of a top-level body, or -1.
int FreeJointOf(const mjModel* m, int body) {
  if (m->body_parentid[body] != 0 || m->body_jntnum[body] != 1) return -1;
  const int j = m->body_jntadr[body];
  return m->jnt_type[j] == mjJNT_FREE ? j : -1;
}

int JointQposAdr(const mjModel* m, const std::string& name, const std::string& what) {
  const int j = NameToId(m, mjOBJ_JOINT, name);
  if (j < 0) throw Error("robot " + what + " joint " + name + " is not in the model");
  return m->jnt_qposadr[j];
}

// robot_files molmospaces: our description of MolmoSpaces' model files for robot `name`
// (RobotsDir()/<name>/molmospaces.yaml) and the installed folder its `mjcf` lives in
// (<assets>/robots/<name>/, spec 2.3).
std::pair<std::filesystem::path, std::filesystem::path> MolmoSpacesRobot(
    const RobotConfig& config, const std::optional<std::filesystem::path>& assets_dir) {
  namespace fs = std::filesystem;
  constexpr char kField[] = "robot_config.robot_files";
  constexpr char kYaml[] = "molmospaces.yaml";
  std::error_code ec;
  if (config.robot_dir || config.name.find('/') != std::string::npos ||
      config.name.ends_with(".yaml")) {
    throw Error(
        "molmospaces uses MolmoSpaces' files of a bundled robot named by "
        "robot_config.name, not a robot.yaml path or robot_dir",
        "", kField);
  }
  const fs::path yaml = RobotsDir() / config.name / kYaml;
  if (!fs::is_regular_file(yaml, ec)) {
    std::vector<std::string> with;
    for (const std::string& robot : robots::BundledRobots()) {
      if (fs::is_regular_file(RobotsDir() / robot / kYaml, ec)) with.push_back(robot);
    }
    throw Error(
        "robot '" + config.name + "' has no description of MolmoSpaces' files (" + yaml.string() +
            "); robots that have one: " + (with.empty() ? std::string("none") : JoinNames(with)),
        "", kField);
  }
  const AssetsDirChoice assets = ResolveAssetsDir(assets_dir);
  const fs::path installed = fs::absolute(assets.dir / "robots" / config.name).lexically_normal();
  if (!fs::is_directory(installed, ec)) {
    const char* from = assets.origin == AssetsDirOrigin::kGiven         ? "libraries.assets_dir"
                       : assets.origin == AssetsDirOrigin::kEnvironment ? "MLSPACES_ASSETS_DIR"
                                                                        : "the default";
    throw Error("molmospaces: MolmoSpaces' robot files are not installed: no folder " +
                    installed.string() + " (assets dir from " + from +
                    "); install them with `mlspaces install --library robots/" + config.name +
                    " --pins FILE` (FILE pins the version, docs/robots.md), or use bundled",
                "", kField);
  }
  return {yaml, installed};
}

}  // namespace

RobotSpec FrankaDroidSpec(const std::filesystem::path& source_dir, const Pose& base,
                          std::string prefix) {
  const std::filesystem::path dir =
      source_dir.empty() ? RobotsDir() / "franka_droid" : source_dir / "assets/robots/franka_droid";
  RobotSpec spec = robots::MakeRobotSpec(robots::LoadRobotDescription(dir), std::move(prefix));
  spec.base = base;
  return spec;
}

RobotSpec RobotSpecFromConfig(const RobotConfig& config, const std::filesystem::path& base_dir,
                              const std::optional<std::filesystem::path>& assets_dir) {
  std::filesystem::path file, mjcf_dir;
  if (config.robot_files == RobotFiles::kMolmoSpaces) {
    std::tie(file, mjcf_dir) = MolmoSpacesRobot(config, assets_dir);
  } else {
    file = config.robot_dir ? robots::FindRobot((*config.robot_dir / "robot.yaml").string(),
                                                base_dir, "robot_config.robot_dir")
                            : robots::FindRobot(config.name, base_dir);
  }
  RobotSpec spec =
      robots::MakeRobotSpec(robots::LoadRobotDescription(file, mjcf_dir), config.robot_namespace);
  if (config.robot_xml_path) {
    spec.xml = *config.robot_xml_path;
    if (std::error_code ec; !std::filesystem::is_regular_file(spec.xml, ec)) {
      throw Error("robot model not found", spec.xml.string(), "robot_config.robot_xml_path");
    }
  }
  auto take = [](const std::vector<double>& given, std::vector<double>& into, size_t size,
                 const char* key, const char* what) {
    if (given.empty()) return;
    if (given.size() != size) {
      throw Error(
          std::to_string(given.size()) + " values, robot has " + std::to_string(size) + " " + what,
          "", key);
    }
    into = given;
  };
  take(config.init_qpos.arm, spec.home_arm, spec.arm_joints.size(), "robot_config.init_qpos.arm",
       "arm joints");
  take(config.init_qpos.gripper, spec.home_gripper, spec.gripper_joints.size(),
       "robot_config.init_qpos.gripper", "gripper joints");
  take(config.init_qpos_noise_range.arm, spec.home_noise, spec.arm_joints.size(),
       "robot_config.init_qpos_noise_range.arm", "arm joints");
  spec.pedestal_size = config.base_size;
  spec.gravcomp = config.gravcomp;
  return spec;
}

Env Env::Load(const std::filesystem::path& scene_xml, const RobotSpec& robot) {
  return Create(sim::Scene::Load(scene_xml), robot, scene_xml.generic_string());
}

Env Env::Create(sim::Scene scene, const RobotSpec& robot, std::string scene_key) {
  robots::InsertRobot(scene, robot);
  Env env;
  sim::ModelPtr compiled = scene.Compile();
  robots::ApplyRobotSettings(compiled.get(), robot);
  env.model_ = std::shared_ptr<const mjModel>(compiled.release(), sim::ModelDeleter{});
  env.data_ =
      std::shared_ptr<mjData>(sim::MakeData(env.model_.get()).release(), sim::DataDeleter{});
  env.robot_ = robot;
  env.robot_base_body_ = robot.prefix + robot.base_body;
  env.scene_key_ = std::move(scene_key);
  env.metadata_ = scene.metadata();
  env.scene_ = std::make_shared<const sim::Scene>(std::move(scene));

  const mjModel* m = env.model_.get();
  env.base_ = std::make_shared<const robots::RobotBase>(m, robot);
  auto check = [&](const std::vector<double>& given, size_t size, const char* what) {
    if (given.size() != size) {
      throw Error(std::string("home ") + what + " pose has " + std::to_string(given.size()) +
                      " values, the robot has " + std::to_string(size) + " joints",
                  robot.description_file.string());
    }
    return given;
  };
  const std::vector<double> arm = check(robot.home_arm, robot.arm_joints.size(), "arm");
  const std::vector<double> gripper =
      check(robot.home_gripper, robot.gripper_joints.size(), "gripper");
  for (size_t i = 0; i < robot.arm_joints.size(); ++i) {
    const std::string name = robot.prefix + robot.arm_joints[i];
    const int adr = JointQposAdr(m, name, "arm");
    env.arm_qpos_adr_.push_back(adr);
    env.home_qpos_adr_.push_back(adr);
    env.home_values_.push_back(arm[i]);
    const std::string servo =
        robot.prefix +
        (i < robot.arm_actuators.size() ? robot.arm_actuators[i] : robot.arm_joints[i]);
    env.arm_actuators_.push_back(NameToId(m, mjOBJ_ACTUATOR, servo));
  }
  for (size_t i = 0; i < robot.gripper_joints.size(); ++i) {
    env.home_qpos_adr_.push_back(
        JointQposAdr(m, robot.prefix + robot.gripper_joints[i], "gripper"));
    env.home_values_.push_back(gripper[i]);
  }
  for (const auto& [follower, driver] : robot.mirrored_joints) {
    env.mirrored_qpos_adr_.emplace_back(JointQposAdr(m, robot.prefix + follower, "gripper"),
                                        JointQposAdr(m, robot.prefix + driver, "gripper"));
  }
  env.Reset();
  return env;
}

void Env::Reset() {
  const mjModel* m = model_.get();
  mjData* d = data_.get();
  mj_resetData(m, d);
  for (size_t i = 0; i < home_qpos_adr_.size(); ++i) d->qpos[home_qpos_adr_[i]] = home_values_[i];
  for (const auto& [follower, driver] : mirrored_qpos_adr_) d->qpos[follower] = -d->qpos[driver];
  for (size_t i = 0; i < arm_actuators_.size(); ++i) {
    if (arm_actuators_[i] >= 0) d->ctrl[arm_actuators_[i]] = home_values_[i];
  }
  SetRobotBasePose(robot_.base);
  mj_forward(m, d);
}

int Env::BodyId(std::string_view name) const {
  const int id = NameToId(model_.get(), mjOBJ_BODY, std::string(name));
  if (id < 0) throw Error("no body named '" + std::string(name) + "' in the model");
  return id;
}

bool Env::IsMovable(std::string_view name) const {
  const int body = BodyId(name);
  return model_->body_mocapid[body] >= 0 || FreeJointOf(model_.get(), body) >= 0;
}

Pose Env::GetBodyPose(std::string_view name) const {
  const mjModel* m = model_.get();
  const mjData* d = data_.get();
  const int body = BodyId(name);
  if (const int mocap = m->body_mocapid[body]; mocap >= 0) {
    return sim::PoseFromMj(d->mocap_pos + 3 * mocap, d->mocap_quat + 4 * mocap);
  }
  if (const int j = FreeJointOf(m, body); j >= 0) {
    const mjtNum* qpos = d->qpos + m->jnt_qposadr[j];
    return sim::PoseFromMj(qpos, qpos + 3);
  }
  return sim::BodyPose(d, body);
}

void Env::SetBodyPose(std::string_view name, const Pose& pose) {
  const mjModel* m = model_.get();
  mjData* d = data_.get();
  const int body = BodyId(name);
  for (double v : ToArray7(pose)) {
    if (!std::isfinite(v)) {
      throw Error("pose of body '" + std::string(name) + "' has a non-finite value");
    }
  }
  const Quat& q = pose.quat;
  double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (norm < 1e-9) {
    throw Error("pose of body '" + std::string(name) + "' has a zero quaternion");
  }
  if (std::abs(norm - 1.0) < 1e-12) norm = 1.0;  // unit already: stored bit for bit
  const Pose unit{pose.pos, {q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm}};
  if (const int mocap = m->body_mocapid[body]; mocap >= 0) {
    sim::PoseToMj(unit, d->mocap_pos + 3 * mocap, d->mocap_quat + 4 * mocap);
  } else if (const int j = FreeJointOf(m, body); j >= 0) {
    const int adr = m->jnt_qposadr[j];
    sim::PoseToMj(unit, d->qpos + adr, d->qpos + adr + 3);
    for (int i = 0; i < 6; ++i) d->qvel[m->jnt_dofadr[j] + i] = 0;
  } else {
    throw Error("body '" + std::string(name) +
                "' cannot be moved: it is neither a mocap body nor a top-level body with a "
                "free joint");
  }
}

void Env::ShareModelAndData(std::shared_ptr<const mjModel> model, std::shared_ptr<mjData> data) {
  if (!model || !data) throw Error("ShareModelAndData: null model or data");
  const mjModel* m = model_.get();
  const mjModel* n = model.get();
  const std::pair<const char*, std::pair<long long, long long>> sizes[] = {
      {"nq", {m->nq, n->nq}},
      {"nv", {m->nv, n->nv}},
      {"nu", {m->nu, n->nu}},
      {"na", {m->na, n->na}},
      {"nbody", {m->nbody, n->nbody}},
      {"njnt", {m->njnt, n->njnt}},
      {"ngeom", {m->ngeom, n->ngeom}},
      {"nsite", {m->nsite, n->nsite}},
      {"ncam", {m->ncam, n->ncam}},
      {"nmocap", {m->nmocap, n->nmocap}},
      {"nsensordata", {m->nsensordata, n->nsensordata}},
      {"neq", {m->neq, n->neq}},
      {"narena", {m->narena, n->narena}},
      {"nbuffer", {m->nbuffer, n->nbuffer}}};
  for (const auto& [name, pair] : sizes) {
    if (pair.first != pair.second) {
      throw Error(std::string("ShareModelAndData: the model's ") + name + " is " +
                  std::to_string(pair.second) + ", the Env's " + std::to_string(pair.first));
    }
  }
  mj_copyData(data.get(), n, data_.get());
  model_ = std::move(model);
  data_ = std::move(data);
}

void Env::ForwardPosition() { mj_fwdPosition(model_.get(), data_.get()); }

void Env::Forward() { mj_forward(model_.get(), data_.get()); }

}  // namespace mlspaces::datagen
