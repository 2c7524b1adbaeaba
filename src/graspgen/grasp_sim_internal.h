// Grasp simulation internals shared by grasp_sim.cc (scene, rigid test, TestCandidates) and
// grasp_sim_joint.cc (articulated test). Not installed.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/graspgen/antipodal.h"
#include "mlspaces/graspgen/grasp_sim.h"
#include "mlspaces/graspgen/mesh.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::graspgen {

struct GraspScene::Impl {
  Mode mode = Mode::kRigid;
  SimParams params;
  std::string source;  // the asset file, for errors
  sim::ModelPtr model;
  int mocap = -1;      // mocap index of the target the hand is welded to
  int hand_qpos = -1;  // the hand's free joint
  int hand_dof = -1;
  int site = -1;      // the TCP site
  int actuator = -1;  // the gripper actuator
  double open_ctrl = 0, closed_ctrl = 255;
  std::vector<int> finger_dofs;  // dof addresses of the gripper's hinge joints
  Mat4 mocap_to_tcp;             // the TCP site in the hand root frame (constant)
  int object = -1;               // object root body (first top-level body of the asset)
  std::vector<int> body_root;    // per body: its top-level ancestor (world: 0)
  /// Per geom: 1 left finger, 2 right finger, 0 anything else.
  std::vector<int> geom_side;
  /// The open hand as boxes in the TCP frame (from the compiled hand's geom AABBs).
  GripperProxy proxy;
  /// The object's collision geometry (root subtree, root body frame, qpos0).
  std::optional<MeshBvh> object_mesh;
  /// The support under the object (rigid scenes): a mocap box whose top face is the plane
  /// z = support_z of the object root frame during the support test, far away otherwise.
  int support_mocap = -1;
  double support_z = 0;
  /// `model` with the data engine's physics (SupportModel), for the support test.
  sim::ModelPtr support_model;

  /// Moves the mocap target so the welded hand pulls its TCP to `tcp_world`.
  void SetTcp(mjData* d, const Mat4& tcp_world) const;
  /// SetTcp, and puts the hand there at rest (before the first step of a test).
  void PlaceHand(mjData* d, const Mat4& tcp_world) const;
  /// Both-finger contact with bodies in `in_set`: bit 1 left, bit 2 right.
  int FingerContacts(const mjData* d, const std::vector<char>& in_set) const;
  /// Steps the gripper closed (at least a few steps, until the fingers stop, at most a cap;
  /// sooner when `abort`, asked every 10 steps, says so). @returns the steps.
  int64_t Close(const mjModel* m, mjData* d, const std::function<bool()>& abort = {}) const;
  /// True when the open hand (proxy) touches the object mesh anywhere on the line TCP + s
  /// away, s in [s_from, s_to] (object-root-frame TCP pose and unit direction), checked every
  /// 5 mm.
  bool HandPathBlocked(const Mat4& tcp_in_root, const Vec3& away, double s_from, double s_to) const;
  /// HandPathBlocked back along the approach line, away = -z of the TCP.
  bool ApproachBlocked(const Mat4& tcp_in_root, double s_from, double s_to) const;
  /// The pick from the support of a grasp that passed the zero-gravity test, or failed it but
  /// clears the support: "" when the object is lifted by lift_height held by both fingers
  /// without slipping at the grasp point (turning up to 30 degrees about it), else the reason.
  /// Adds its mj_step calls to `steps`.
  std::string TestOnSupport(const Mat4& tcp_in_root, mjData* d, int64_t& steps) const;
};

/// Rigid tests (zero gravity and on the support): how far the object may move before the
/// fingers close, and the steps between slip checks (contacts: at the load peaks).
inline constexpr double kApproachMotion = 0.002;  // m
inline constexpr double kApproachTurn = 0.05;     // rad
inline constexpr int kSlipEvery = 10;

/// The support mocap body's half thickness (m) and its resting place between tests.
inline constexpr double kSupportHalfThickness = 0.01;
inline constexpr double kSupportAway = -100;
/// Adds the support body to a rigid scene's spec (before compiling).
void AddSupport(mjSpec* spec);
/// A copy of a rigid scene's model with MolmoSpaces' data-engine physics (the scene's option:
/// implicit, default pyramidal cone, impratio 1, no no-slip; multi-contact CCD kept), where the
/// grasps are used. Same sizes, so the scene's mjData serve it too.
sim::ModelPtr SupportModel(const mjModel* m);

/// Rigid transform of a body / site from mjData.
Mat4 BodyMat4(const mjData* d, int body);

}  // namespace mlspaces::graspgen
