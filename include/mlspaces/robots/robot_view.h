// A robot's handles in a compiled model: the ids and addresses of its arm joints and servos,
// gripper drivers and actuator, TCP site, finger pads and base, resolved once from a RobotSpec,
// with the reads and writes the planner, the controller and the recorder make every step.
//
// Lifetimes: the model must outlive the view; the mjData passed to each call is used during
// the call only. The references the accessors return are valid while the view lives.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <span>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"
#include "mlspaces/robots/robot_spec.h"

namespace mlspaces::robots {

class MLSPACES_API RobotView {
 public:
  // ===========================================================================================
  // Construction

  /// Resolves every name of `spec` (under its prefix) in `m`, which must outlive the view.
  /// @throws Error naming the first element that is missing, or an arm joint without a
  /// position servo of its name.
  RobotView(const mjModel* m, const RobotSpec& spec);

  // ===========================================================================================
  // Joints and actuators

  size_t num_arm() const { return arm_qpos_.size(); }
  size_t num_gripper() const { return gripper_qpos_.size(); }

  std::vector<double> ArmQpos(const mjData* d) const;
  std::vector<double> ArmQvel(const mjData* d) const;
  std::vector<double> GripperQpos(const mjData* d) const;
  std::vector<double> GripperQvel(const mjData* d) const;

  /// The arm servos' targets (ctrl).
  std::vector<double> ArmTargets(const mjData* d) const;
  /// Sets the arm servo targets, each clipped to its actuator's ctrlrange (when limited).
  void SetArmTargets(mjData* d, std::span<const double> q) const;
  double GripperCtrl(const mjData* d) const;
  /// Sets the gripper ctrl, clipped to the actuator's ctrlrange.
  void SetGripperCtrl(mjData* d, double ctrl) const;

  // ===========================================================================================
  // Arm joints: limits, names, addresses

  /// Joint limits of the arm (lower, upper); unlimited joints get -inf / +inf.
  const std::vector<double>& arm_lower() const { return arm_lower_; }
  const std::vector<double>& arm_upper() const { return arm_upper_; }
  /// Full (prefixed) arm joint names, in spec order.
  const std::vector<std::string>& arm_joint_names() const { return arm_names_; }
  /// qpos addresses of the arm joints, in spec order.
  const std::vector<int>& arm_qpos_adr() const { return arm_qpos_; }

  // ===========================================================================================
  // Kinematics and geometry

  /// World pose of the TCP site (after kinematics).
  Mat4 TcpPose(const mjData* d) const;
  /// World pose of the robot base: its mocap state, else its body frame (after kinematics).
  Mat4 BasePose(const mjData* d) const;

  /// Distance between the two finger pad geoms (mj_geomDistance), clamped at 0 (needs
  /// kinematics).
  double InterFingerDistance(const mjData* d) const;

  /// The 6 x num_arm() Jacobian of the TCP site over the arm dofs, row-major, rows
  /// [linear xyz; angular xyz] in the world frame (needs kinematics and com positions).
  std::vector<double> ArmJacobian(const mjData* d) const;

  /// True when geom `g` belongs to the gripper subtree.
  bool IsGripperGeom(int g) const;

  // ===========================================================================================
  // Stepping

  /// `n` physics steps (mj_step; gravity compensation is MuJoCo's body gravcomp).
  void Step(mjData* d, int n) const;

  // ===========================================================================================
  // Ids in the model, and the spec

  int tcp_site() const { return tcp_site_; }
  int base_body() const { return base_body_; }
  int gripper_body() const { return gripper_body_; }
  int gripper_actuator() const { return gripper_act_; }
  const RobotSpec& spec() const { return spec_; }

 private:
  const mjModel* m_;
  RobotSpec spec_;
  std::vector<std::string> arm_names_;
  std::vector<int> arm_qpos_, arm_dof_, arm_act_;
  std::vector<double> arm_lower_, arm_upper_;
  std::vector<int> gripper_qpos_, gripper_dof_;
  std::vector<char> gripper_geom_;  // per geom: in the gripper subtree
  std::array<int, 2> pads_{-1, -1};
  int gripper_act_ = -1;
  int tcp_site_ = -1;
  int base_body_ = -1;
  int base_mocap_ = -1;
  int gripper_body_ = -1;
};

}  // namespace mlspaces::robots
