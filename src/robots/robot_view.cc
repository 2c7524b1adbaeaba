#include "mlspaces/robots/robot_view.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::robots {
namespace {

int Require(const mjModel* m, mjtObj type, const std::string& name, const char* what) {
  const int id = mj_name2id(m, type, name.c_str());
  if (id < 0) throw Error(std::string("robot ") + what + " '" + name + "' is not in the model");
  return id;
}

}  // namespace

RobotView::RobotView(const mjModel* m, const RobotSpec& spec) : m_(m), spec_(spec) {
  const std::string& p = spec.prefix;
  for (size_t i = 0; i < spec.arm_joints.size(); ++i) {
    const std::string name = p + spec.arm_joints[i];
    const std::string servo =
        p + (i < spec.arm_actuators.size() ? spec.arm_actuators[i] : spec.arm_joints[i]);
    const int j = Require(m, mjOBJ_JOINT, name, "arm joint");
    arm_names_.push_back(name);
    arm_qpos_.push_back(m->jnt_qposadr[j]);
    arm_dof_.push_back(m->jnt_dofadr[j]);
    arm_act_.push_back(Require(m, mjOBJ_ACTUATOR, servo, "arm servo"));
    const bool limited = m->jnt_limited[j] != 0;
    arm_lower_.push_back(limited ? m->jnt_range[2 * j] : -std::numeric_limits<double>::infinity());
    arm_upper_.push_back(limited ? m->jnt_range[2 * j + 1]
                                 : std::numeric_limits<double>::infinity());
  }
  for (const std::string& joint : spec.gripper_joints) {
    const int j = Require(m, mjOBJ_JOINT, p + joint, "gripper joint");
    gripper_qpos_.push_back(m->jnt_qposadr[j]);
    gripper_dof_.push_back(m->jnt_dofadr[j]);
  }
  gripper_act_ = Require(m, mjOBJ_ACTUATOR, p + spec.gripper_actuator, "gripper actuator");
  tcp_site_ = Require(m, mjOBJ_SITE, p + spec.tcp_site, "TCP site");
  base_body_ = Require(m, mjOBJ_BODY, p + spec.base_body, "base body");
  base_mocap_ = m->body_mocapid[base_body_];
  if (base_mocap_ < 0 && spec.base_kind == BaseKind::kMocap) {
    throw Error("robot base body '" + p + spec.base_body + "' is not mocap");
  }
  gripper_body_ = Require(m, mjOBJ_BODY, p + spec.gripper_body, "gripper body");
  for (int k = 0; k < 2; ++k) {
    pads_[k] = Require(m, mjOBJ_GEOM, p + spec.finger_pads[k], "finger pad");
  }
  Require(m, mjOBJ_BODY, p + spec.arm_root_body, "arm root body");
  gripper_geom_.assign(m->ngeom, 0);
  for (int g = 0; g < m->ngeom; ++g) {
    for (int b = m->geom_bodyid[g]; b > 0; b = m->body_parentid[b]) {
      if (b == gripper_body_) {
        gripper_geom_[g] = 1;
        break;
      }
    }
  }
}

namespace {
std::vector<double> Gather(const mjtNum* values, const std::vector<int>& adr) {
  std::vector<double> out(adr.size());
  for (size_t i = 0; i < adr.size(); ++i) out[i] = values[adr[i]];
  return out;
}

double ClipToCtrlRange(const mjModel* m, int act, double value) {
  if (!m->actuator_ctrllimited[act]) return value;
  return std::clamp(value, m->actuator_ctrlrange[2 * act], m->actuator_ctrlrange[2 * act + 1]);
}
}  // namespace

std::vector<double> RobotView::ArmQpos(const mjData* d) const { return Gather(d->qpos, arm_qpos_); }
std::vector<double> RobotView::ArmQvel(const mjData* d) const { return Gather(d->qvel, arm_dof_); }
std::vector<double> RobotView::GripperQpos(const mjData* d) const {
  return Gather(d->qpos, gripper_qpos_);
}
std::vector<double> RobotView::GripperQvel(const mjData* d) const {
  return Gather(d->qvel, gripper_dof_);
}
std::vector<double> RobotView::ArmTargets(const mjData* d) const {
  return Gather(d->ctrl, arm_act_);
}

void RobotView::SetArmTargets(mjData* d, std::span<const double> q) const {
  if (q.size() != arm_act_.size()) {
    throw Error("arm target has " + std::to_string(q.size()) + " values, the arm has " +
                std::to_string(arm_act_.size()) + " joints");
  }
  for (size_t i = 0; i < q.size(); ++i)
    d->ctrl[arm_act_[i]] = ClipToCtrlRange(m_, arm_act_[i], q[i]);
}

double RobotView::GripperCtrl(const mjData* d) const { return d->ctrl[gripper_act_]; }

void RobotView::SetGripperCtrl(mjData* d, double ctrl) const {
  d->ctrl[gripper_act_] = ClipToCtrlRange(m_, gripper_act_, ctrl);
}

Mat4 RobotView::TcpPose(const mjData* d) const { return sim::SiteMat4(d, tcp_site_); }

Mat4 RobotView::BasePose(const mjData* d) const {
  if (base_mocap_ < 0) return sim::FrameToMat4(d->xpos + 3 * base_body_, d->xmat + 9 * base_body_);
  return ToMat4(sim::PoseFromMj(d->mocap_pos + 3 * base_mocap_, d->mocap_quat + 4 * base_mocap_));
}

double RobotView::InterFingerDistance(const mjData* d) const {
  // MuJoCo's distance between the two pad geoms, as the original measures it (up to 1 m;
  // negative while they press into each other).
  const mjtNum dist = mj_geomDistance(m_, d, pads_[0], pads_[1], 1.0, nullptr);
  return std::max(0.0, static_cast<double>(dist));
}

std::vector<double> RobotView::ArmJacobian(const mjData* d) const {
  const int nv = m_->nv;
  std::vector<double> jacp(3 * nv), jacr(3 * nv);
  mj_jacSite(m_, d, jacp.data(), jacr.data(), tcp_site_);
  const size_t n = arm_dof_.size();
  std::vector<double> jac(6 * n);
  for (int r = 0; r < 3; ++r) {
    for (size_t i = 0; i < n; ++i) {
      jac[r * n + i] = jacp[r * nv + arm_dof_[i]];
      jac[(3 + r) * n + i] = jacr[r * nv + arm_dof_[i]];
    }
  }
  return jac;
}

bool RobotView::IsGripperGeom(int g) const {
  return g >= 0 && g < static_cast<int>(gripper_geom_.size()) && gripper_geom_[g] != 0;
}

void RobotView::Step(mjData* d, int n) const {
  for (int i = 0; i < n; ++i) mj_step(m_, d);
}

}  // namespace mlspaces::robots
