#include "mlspaces/datagen/env.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/config.h"
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

std::vector<double> Numeric(const mjModel* m, const std::string& name, size_t size) {
  const int id = NameToId(m, mjOBJ_NUMERIC, name);
  if (id < 0) throw Error("the model has no custom numeric " + name + " (the robot's home pose)");
  if (static_cast<size_t>(m->numeric_size[id]) != size) {
    throw Error("custom numeric " + name + " has " + std::to_string(m->numeric_size[id]) +
                " values, the robot spec lists " + std::to_string(size) + " joints");
  }
  const mjtNum* data = m->numeric_data + m->numeric_adr[id];
  return std::vector<double>(data, data + size);
}

}  // namespace

RobotSpec FrankaDroidSpec(const std::filesystem::path& source_dir, const Pose& base,
                          std::string prefix) {
  RobotSpec spec;
  spec.xml = source_dir / "assets/robots/franka_droid/franka_droid.xml";
  spec.prefix = std::move(prefix);
  spec.base = base;
  for (int i = 1; i <= 7; ++i) spec.arm_joints.push_back("fr3_joint" + std::to_string(i));
  spec.gripper_joints = {"gripper/left_driver_joint", "gripper/right_driver_joint"};
  spec.mirrored_joints = {{"gripper/left_follower_joint", "gripper/left_driver_joint"},
                          {"gripper/right_follower_joint", "gripper/right_driver_joint"}};
  return spec;
}

std::filesystem::path RobotsDir() {
  if (const char* dir = std::getenv("MLSPACES_ROBOTS_DIR"); dir != nullptr && *dir != 0) {
    return dir;
  }
  // The source tree's copy while it exists (a build tree); an installed package's copy
  // (`cmake --install`: <prefix>/share/mlspaces/robots) once the sources are gone.
  std::filesystem::path source = MLSPACES_DEFAULT_ROBOTS_DIR;
  if (std::error_code ec; std::filesystem::is_directory(source, ec)) return source;
  return MLSPACES_INSTALLED_ROBOTS_DIR;
}

RobotSpec RobotSpecFromConfig(const RobotConfig& config) {
  if (config.name != "franka_droid") {
    throw Error("unknown robot '" + config.name + "' (mlspaces has: franka_droid)", "",
                "robot_config.name");
  }
  RobotSpec spec = FrankaDroidSpec({}, {}, config.robot_namespace);
  spec.xml = config.robot_xml_path ? *config.robot_xml_path
                                   : RobotsDir() / config.name / (config.name + ".xml");
  if (std::error_code ec; !std::filesystem::is_regular_file(spec.xml, ec)) {
    throw Error("robot model not found (set MLSPACES_ROBOTS_DIR or robot_config.robot_xml_path)",
                spec.xml.string(), "robot_config.robot_xml_path");
  }
  spec.pedestal_size = config.base_size;
  spec.gravcomp = config.gravcomp;
  spec.home_arm.assign(config.init_qpos.arm.begin(), config.init_qpos.arm.end());
  spec.home_gripper.assign(config.init_qpos.gripper.begin(), config.init_qpos.gripper.end());
  return spec;
}

Env Env::Load(const std::filesystem::path& scene_xml, const RobotSpec& robot) {
  return Create(sim::Scene::Load(scene_xml), robot, scene_xml.generic_string());
}

namespace {

// The robot standing on a box pedestal: a wrapper model whose mocap base holds the box and
// the robot's arm subtree mounted on top (MuJoCo's <attach> of the robot's <model>).
void InsertRobotOnPedestal(sim::Scene& scene, const RobotSpec& robot) {
  const std::array<double, 3>& size = *robot.pedestal_size;
  char buf[128];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(buf);
  };
  const std::string xml =
      "<mujoco model=\"robot_on_pedestal\">\n"
      "  <asset><model name=\"robot\" file=\"" +
      std::filesystem::absolute(robot.xml).string() +
      "\"/></asset>\n"
      "  <worldbody>\n"
      "    <body name=\"" +
      robot.base_body +
      "\" mocap=\"true\">\n"
      "      <geom name=\"pedestal\" type=\"box\" size=\"" +
      num(size[0] / 2) + " " + num(size[1] / 2) + " " + num(size[2] / 2) + "\" pos=\"0 0 " +
      num(size[2] / 2) +
      "\" group=\"0\" rgba=\"0.35 0.25 0.18 1\" mass=\"20\"/>\n"
      "      <frame pos=\"0 0 " +
      num(size[2]) +
      "\">\n"
      "        <attach model=\"robot\" body=\"" +
      robot.arm_root_body +
      "\" prefix=\"\"/>\n"
      "      </frame>\n"
      "    </body>\n"
      "  </worldbody>\n"
      "</mujoco>\n";
  scene.InsertRobotString(
      xml, std::filesystem::absolute(robot.xml).parent_path() / "robot_on_pedestal.xml",
      robot.prefix, robot.base);
}

// robot_config.gravcomp on the compiled model: body_gravcomp 1 (or 0) on the arm root's
// subtree, and ngravcomp recounted (MuJoCo skips gravity compensation when it is 0).
void SetRobotGravcomp(mjModel* m, const RobotSpec& robot) {
  const std::string root_name = robot.prefix + robot.arm_root_body;
  const int root = NameToId(m, mjOBJ_BODY, root_name);
  if (root < 0)
    throw Error("robot arm root body " + root_name + " is not in the model", robot.xml.string());
  for (int b = 1; b < m->nbody; ++b) {
    int a = b;
    while (a > 0 && a != root) a = m->body_parentid[a];
    if (a == root) m->body_gravcomp[b] = robot.gravcomp ? 1 : 0;
  }
  m->ngravcomp = 0;
  for (int b = 0; b < m->nbody; ++b) m->ngravcomp += m->body_gravcomp[b] != 0;
}

}  // namespace

Env Env::Create(sim::Scene scene, const RobotSpec& robot, std::string scene_key) {
  if (robot.pedestal_size) {
    InsertRobotOnPedestal(scene, robot);
  } else {
    scene.InsertRobot(robot.xml, robot.prefix, robot.base);
  }
  Env env;
  sim::ModelPtr compiled = scene.Compile();
  SetRobotGravcomp(compiled.get(), robot);
  env.model_ = std::shared_ptr<const mjModel>(compiled.release(), sim::ModelDeleter{});
  env.data_ =
      std::shared_ptr<mjData>(sim::MakeData(env.model_.get()).release(), sim::DataDeleter{});
  env.robot_ = robot;
  env.robot_base_body_ = robot.prefix + robot.base_body;
  env.scene_key_ = std::move(scene_key);
  env.metadata_ = scene.metadata();
  env.scene_ = std::make_shared<const sim::Scene>(std::move(scene));

  const mjModel* m = env.model_.get();
  const int base = NameToId(m, mjOBJ_BODY, env.robot_base_body_);
  if (base < 0 || m->body_mocapid[base] < 0) {
    throw Error("robot base " + env.robot_base_body_ + " is not a mocap body of the model",
                robot.xml.string());
  }
  auto home = [&](const std::vector<double>& given, const std::string& numeric, size_t size,
                  const char* what) {
    if (given.empty()) return Numeric(m, robot.prefix + numeric, size);
    if (given.size() != size) {
      throw Error(std::string("home ") + what + " pose has " + std::to_string(given.size()) +
                  " values, the robot has " + std::to_string(size) + " joints");
    }
    return given;
  };
  const std::vector<double> arm =
      home(robot.home_arm, robot.home_arm_numeric, robot.arm_joints.size(), "arm");
  const std::vector<double> gripper =
      home(robot.home_gripper, robot.home_gripper_numeric, robot.gripper_joints.size(), "gripper");
  for (size_t i = 0; i < robot.arm_joints.size(); ++i) {
    const std::string name = robot.prefix + robot.arm_joints[i];
    const int adr = JointQposAdr(m, name, "arm");
    env.arm_qpos_adr_.push_back(adr);
    env.home_qpos_adr_.push_back(adr);
    env.home_values_.push_back(arm[i]);
    env.arm_actuators_.push_back(NameToId(m, mjOBJ_ACTUATOR, name));
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
