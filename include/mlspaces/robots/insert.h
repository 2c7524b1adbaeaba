// Putting a robot into a scene: its base (mocap, holonomic or fixed), the optional pedestal,
// gravity compensation, and the base pose's reads and writes.
//
// Lifetimes: the model and data passed in are used during each call only.
#pragma once

#include "mlspaces/core/export.h"

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"
#include "mlspaces/robots/robot_spec.h"
#include "mlspaces/sim/scene.h"

namespace mlspaces::robots {

/// Inserts `robot` into `scene` under robot.prefix at robot.base. An MJCF that holds its own
/// base body and needs no pedestal goes in as it is; otherwise mlspaces wraps the arm root in
/// a base body `base_body`: a mocap body (kMocap), a body on slide x, slide y and hinge yaw
/// joints `base_x`, `base_y`, `base_yaw` with position servos of the same names (kHolonomic;
/// kp 25000, 25000, 5000 as the original's mobile bases), or a plain body (kFixed); the
/// pedestal box (robot.pedestal_size) stands on the base frame with the arm root on its top.
/// @throws Error from the composer (bad MJCF, name clashes).
MLSPACES_API void InsertRobot(sim::Scene& scene, const RobotSpec& robot);

/// Applies robot.gravcomp to a compiled model: body_gravcomp 1 (or 0) on the arm root's
/// subtree, ngravcomp recounted. @throws Error when the root body is not in `m`.
MLSPACES_API void ApplyRobotSettings(mjModel* m, const RobotSpec& robot);

/// The robot's base in a compiled model: reads and writes its world pose as state.
class MLSPACES_API RobotBase {
 public:
  /// @throws Error naming the base body when it is missing or does not match robot.base_kind.
  RobotBase(const mjModel* m, const RobotSpec& robot);

  /// The base pose: mocap state, or (holonomic) the joints' x, y, yaw over the inserted pose,
  /// or (fixed) the body's compiled pose.
  Pose Get(const mjModel* m, const mjData* d) const;
  /// Writes the base pose into the state (mocap pose, or the holonomic joints and their servo
  /// targets). @throws Error for a fixed base moved away from its pose, or a holonomic base
  /// asked for a height, roll or pitch other than its own.
  void Set(const mjModel* m, mjData* d, const Pose& pose) const;

  BaseKind kind() const { return kind_; }
  int body() const { return body_; }

 private:
  BaseKind kind_;
  std::string name_;
  std::string file_;  // the robot.yaml, for errors
  int body_ = -1;
  int mocap_ = -1;
  int qpos_[3] = {-1, -1, -1};  // holonomic x, y, yaw
  int dof_[3] = {-1, -1, -1};
  int act_[3] = {-1, -1, -1};
};

}  // namespace mlspaces::robots
