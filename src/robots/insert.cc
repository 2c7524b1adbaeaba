#include "mlspaces/robots/insert.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::robots {
namespace {

constexpr const char* kHoloJoints[3] = {"base_x", "base_y", "base_yaw"};

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// The wrapper model: the base body holding the pedestal (if any) and the arm root on top
// (MuJoCo's <attach> of the robot's <model>).
std::string WrapperXml(const RobotSpec& robot) {
  const std::string file = std::filesystem::absolute(robot.xml).string();
  std::string body_attrs;
  std::string joints;
  std::string actuators;
  switch (robot.base_kind) {
    case BaseKind::kMocap:
      body_attrs = " mocap=\"true\"";
      break;
    case BaseKind::kHolonomic: {
      const char* types[3] = {"slide", "slide", "hinge"};
      const char* axes[3] = {"1 0 0", "0 1 0", "0 0 1"};
      const char* kp[3] = {"25000", "25000", "5000"};
      const char* range[3] = {"-25 25", "-25 25", "-3.1415926535897931 3.1415926535897931"};
      joints = "      <inertial pos=\"0 0 0\" mass=\"10\" diaginertia=\"1 1 1\"/>\n";
      actuators = "  <actuator>\n";
      for (int i = 0; i < 3; ++i) {
        joints += std::string("      <joint name=\"") + kHoloJoints[i] + "\" type=\"" + types[i] +
                  "\" axis=\"" + axes[i] + "\" damping=\"100\"/>\n";
        actuators += std::string("    <position name=\"") + kHoloJoints[i] + "\" joint=\"" +
                     kHoloJoints[i] + "\" kp=\"" + kp[i] + "\" kv=\"" + (i < 2 ? "2500" : "500") +
                     "\" ctrlrange=\"" + range[i] + "\"/>\n";
      }
      actuators += "  </actuator>\n";
      break;
    }
    case BaseKind::kFixed:
      break;
  }
  std::string xml = "<mujoco model=\"robot_on_pedestal\">\n  <asset><model name=\"robot\" file=\"" +
                    file + "\"/></asset>\n  <worldbody>\n    <body name=\"" + robot.base_body +
                    "\"" + body_attrs + ">\n" + joints;
  double top = 0;
  if (robot.pedestal_size) {
    const std::array<double, 3>& size = *robot.pedestal_size;
    top = size[2];
    xml += "      <geom name=\"pedestal\" type=\"box\" size=\"" + Num(size[0] / 2) + " " +
           Num(size[1] / 2) + " " + Num(size[2] / 2) + "\" pos=\"0 0 " + Num(size[2] / 2) +
           "\" group=\"0\" rgba=\"0.35 0.25 0.18 1\" mass=\"20\"/>\n";
  }
  xml += "      <frame pos=\"0 0 " + Num(top) + "\">\n        <attach model=\"robot\" body=\"" +
         robot.arm_root_body + "\" prefix=\"\"/>\n      </frame>\n    </body>\n  </worldbody>\n" +
         actuators + "</mujoco>\n";
  return xml;
}

double Yaw(const Quat& q) {
  return std::atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
}

}  // namespace

void InsertRobot(sim::Scene& scene, const RobotSpec& robot) {
  if (robot.base_in_model && !robot.pedestal_size) {
    scene.InsertRobot(robot.xml, robot.prefix, robot.base);
    return;
  }
  // A holonomic base goes in upright at the base height; its joints carry x, y and yaw.
  Pose at = robot.base;
  if (robot.base_kind == BaseKind::kHolonomic) at = Pose{{0, 0, robot.base.pos[2]}, {1, 0, 0, 0}};
  scene.InsertRobotString(
      WrapperXml(robot),
      std::filesystem::absolute(robot.xml).parent_path() / "robot_on_pedestal.xml", robot.prefix,
      at);
}

void ApplyRobotSettings(mjModel* m, const RobotSpec& robot) {
  const std::string root_name = robot.prefix + robot.arm_root_body;
  const int root = mj_name2id(m, mjOBJ_BODY, root_name.c_str());
  if (root < 0) {
    throw Error("robot arm root body " + root_name + " is not in the model", robot.xml.string());
  }
  for (int b = 1; b < m->nbody; ++b) {
    int a = b;
    while (a > 0 && a != root) a = m->body_parentid[a];
    if (a == root) m->body_gravcomp[b] = robot.gravcomp ? 1 : 0;
  }
  m->ngravcomp = 0;
  for (int b = 0; b < m->nbody; ++b) m->ngravcomp += m->body_gravcomp[b] != 0;
}

RobotBase::RobotBase(const mjModel* m, const RobotSpec& robot)
    : kind_(robot.base_kind),
      name_(robot.prefix + robot.base_body),
      file_(robot.description_file.string()) {
  body_ = mj_name2id(m, mjOBJ_BODY, name_.c_str());
  if (body_ < 0)
    throw Error("robot base body " + name_ + " is not in the model", robot.xml.string());
  mocap_ = m->body_mocapid[body_];
  if (kind_ == BaseKind::kMocap && mocap_ < 0) {
    throw Error("robot base " + name_ + " is not a mocap body of the model", robot.xml.string());
  }
  if (kind_ == BaseKind::kHolonomic) {
    for (int i = 0; i < 3; ++i) {
      const std::string joint = robot.prefix + kHoloJoints[i];
      const int j = mj_name2id(m, mjOBJ_JOINT, joint.c_str());
      const int a = mj_name2id(m, mjOBJ_ACTUATOR, joint.c_str());
      if (j < 0 || a < 0 || m->jnt_bodyid[j] != body_) {
        throw Error("holonomic base joint or servo " + joint + " is not in the model",
                    robot.xml.string());
      }
      qpos_[i] = m->jnt_qposadr[j];
      dof_[i] = m->jnt_dofadr[j];
      act_[i] = a;
    }
  }
}

Pose RobotBase::Get(const mjModel* m, const mjData* d) const {
  if (mocap_ >= 0) return sim::PoseFromMj(d->mocap_pos + 3 * mocap_, d->mocap_quat + 4 * mocap_);
  if (kind_ == BaseKind::kHolonomic) {
    const double yaw = d->qpos[qpos_[2]];
    return Pose{{d->qpos[qpos_[0]], d->qpos[qpos_[1]], m->body_pos[3 * body_ + 2]},
                {std::cos(yaw / 2), 0, 0, std::sin(yaw / 2)}};
  }
  return sim::PoseFromMj(m->body_pos + 3 * body_, m->body_quat + 4 * body_);
}

void RobotBase::Set(const mjModel* m, mjData* d, const Pose& pose) const {
  for (double v : ToArray7(pose)) {
    if (!std::isfinite(v)) throw Error("robot base pose has a non-finite value", "", name_);
  }
  if (kind_ == BaseKind::kFixed) {
    const Pose fixed = Get(m, d);
    double err = 0;
    for (int i = 0; i < 3; ++i) err = std::max(err, std::abs(fixed.pos[i] - pose.pos[i]));
    if (err > 1e-9 ||
        std::abs(std::abs(QuatMul(QuatConjugate(fixed.quat), pose.quat)[0]) - 1) > 1e-9) {
      throw Error(
          "the robot's base " + name_ +
              " is fixed and cannot be moved; use kind mocap or holonomic for tasks that place "
              "the robot",
          file_, "base.kind");
    }
    return;
  }
  const Quat& given = pose.quat;
  double norm = std::sqrt(given[0] * given[0] + given[1] * given[1] + given[2] * given[2] +
                          given[3] * given[3]);
  if (norm < 1e-9) throw Error("robot base pose has a zero quaternion", "", name_);
  if (std::abs(norm - 1.0) < 1e-12) norm = 1.0;  // unit already: stored bit for bit
  const Quat q{given[0] / norm, given[1] / norm, given[2] / norm, given[3] / norm};
  if (mocap_ >= 0) {
    sim::PoseToMj(Pose{pose.pos, q}, d->mocap_pos + 3 * mocap_, d->mocap_quat + 4 * mocap_);
    return;
  }
  // Upright: the quaternion is a rotation about z alone.
  if (std::abs(q[1]) > 1e-9 || std::abs(q[2]) > 1e-9 ||
      std::abs(pose.pos[2] - m->body_pos[3 * body_ + 2]) > 1e-9) {
    throw Error("the holonomic base " + name_ +
                    " moves in x, y and yaw only: the pose's height, roll or pitch differs from "
                    "the base's",
                file_, "base.kind");
  }
  const double values[3] = {pose.pos[0], pose.pos[1], Yaw(q)};
  for (int i = 0; i < 3; ++i) {
    d->qpos[qpos_[i]] = values[i];
    d->qvel[dof_[i]] = 0;
    d->ctrl[act_[i]] = values[i];
  }
}

}  // namespace mlspaces::robots
