// `mlspaces inspect-robot`: checks a robot description and measures the robot in simulation.
//
// InspectRobot loads a robot.yaml with CheckRobotDescription (every problem, one line each),
// inserts the robot alone into an empty scene (a floor; timestep 0.002 s, implicitfast), and
// reports its kinematic chain, actuators, home pose, the TCP convention (spec 13), the
// gripper's travel measured in simulation and IK reachability over a workspace grid. Every
// problem is one line "<robot.yaml>: <field>: <problem>". Deterministic: the same robot and
// options give the same report.
//
// Lifetimes: plain values, no references kept.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/json.h"
#include "mlspaces/core/transform.h"

namespace mlspaces::robots {

struct MLSPACES_API InspectOptions {
  /// Seconds simulated after opening and again after closing the gripper (> 0).
  double settle_time = 1.0;
  /// A measured gap further than this from robot.yaml's finger_range is a problem (m).
  double finger_tolerance = 0.002;
  /// Largest angle (degrees) between the TCP's +z and the palm-to-pads direction, and between
  /// its y axis and the line between the pads.
  double tcp_tolerance_deg = 10.0;
  /// The reachability grid in the base frame (m): [min, max] per axis, inclusive, `grid_step`
  /// apart; each point is a target with the TCP pointing down (+z of TCP = base -z).
  std::array<double, 2> grid_x{0.3, 0.8};
  std::array<double, 2> grid_y{-0.4, 0.4};
  std::array<double, 2> grid_z{0.05, 0.6};
  double grid_step = 0.1;
  /// False: skip the reachability grid (the costliest part).
  bool reachability = true;
};

/// One joint of a body on the kinematic chain.
struct MLSPACES_API ChainJoint {
  std::string name;                            ///< before the robot prefix
  std::string type;                            ///< hinge, slide, ball or free
  Vec3 axis{0, 0, 0};                          ///< in the body frame
  std::optional<std::array<double, 2>> range;  ///< null: unlimited
  bool arm = false;                            ///< listed in arm.joints
};

/// One body from root_body to the TCP site's body, with its joints.
struct MLSPACES_API ChainBody {
  std::string name;
  std::vector<ChainJoint> joints;
};

/// An arm actuator or the gripper actuator.
struct MLSPACES_API ActuatorReport {
  std::string name;
  std::string target;                                ///< the joint or tendon it drives
  std::optional<std::array<double, 2>> ctrl_range;   ///< null: unlimited
  std::optional<std::array<double, 2>> force_range;  ///< null: unlimited
  double gain = 0;                                   ///< gainprm[0] (kp of a position servo)
  std::array<double, 3> bias{0, 0, 0};  ///< biasprm[0..2] (0, -kp, -kv for a position servo)
};

/// Each measured section has `skipped`: empty when measured, else why it was not.
struct MLSPACES_API HomeReport {
  std::string skipped;
  bool within_limits = true;  ///< arm and gripper home values within their joints' ranges
  Pose tcp;                   ///< TCP pose at home in the base frame
};

struct MLSPACES_API TcpReport {
  std::string skipped;
  bool ok = false;
  /// Angle (degrees) between the TCP's +z and the direction from the gripper body's origin
  /// (the palm) to the finger pads' midpoint.
  double approach_angle_deg = 0;
  /// Angle (degrees) between the line through the two pads and the TCP's y axis (either sign).
  double finger_axis_angle_deg = 0;
  /// The pads' midpoint in the TCP frame (m).
  Vec3 pad_midpoint_in_tcp{0, 0, 0};
};

struct MLSPACES_API GripperTravelReport {
  std::string skipped;
  double settle_time = 0;                ///< s simulated per state
  bool gravcomp = false;                 ///< robot.yaml's gravcomp, applied while measuring
  double open_gap = 0;                   ///< measured inter-finger distance after open_ctrl (m)
  double closed_gap = 0;                 ///< after closed_ctrl (m)
  std::array<double, 2> declared{0, 0};  ///< robot.yaml's finger_range [closed, open]
  bool ok = false;                       ///< both within the tolerance
};

struct MLSPACES_API ReachabilityReport {
  std::string skipped;
  std::array<double, 2> grid_x{0, 0}, grid_y{0, 0}, grid_z{0, 0};
  double grid_step = 0;
  int targets = 0;
  int reached = 0;
  /// Min and max x, y, z of the reached targets (base frame); null when none is reached.
  std::optional<std::array<Vec3, 2>> envelope;
};

/// What `mlspaces inspect-robot` found.
struct MLSPACES_API RobotReport {
  std::filesystem::path file;  ///< the robot.yaml
  std::string name;            ///< robot.yaml's name ("" when it does not load)
  std::string hash;            ///< the description hash (robot_spec.h)
  /// Every problem, one line "<file>: <field>: <problem>"; empty = none.
  std::vector<std::string> problems;
  /// False when the description does not load (unparseable YAML, an MJCF that is missing or
  /// does not compile, a robot that cannot be inserted): then only `problems` is filled.
  bool loaded = false;
  std::vector<ChainBody> chain;  ///< root_body .. the TCP site's body
  std::vector<ActuatorReport> arm_actuators;
  std::optional<ActuatorReport> gripper_actuator;
  int arm_dof = 0;                 ///< arm joints found in the model
  int gripper_dof = 0;             ///< dofs in the gripper body's subtree
  int gripper_drivers = 0;         ///< gripper.joints found in the model
  int robot_nq = 0, robot_nv = 0;  ///< the whole inserted robot (base joints included)
  HomeReport home;
  TcpReport tcp;
  GripperTravelReport gripper;
  ReachabilityReport reachability;
};

/// Inspects the robot `name_or_path` means (FindRobot: a bundled name, or a robot.yaml or its
/// folder; relative paths against the working directory). Problems with the robot go into
/// the report. @throws Error for an unknown name or a path without a robot.yaml (with the
/// bundled names and a "did you mean"); UsageError for bad options.
MLSPACES_API RobotReport InspectRobot(std::string_view name_or_path,
                                      const InspectOptions& options = {});

/// The report as JSON (the CLI's --json, Python's inspect_robot dict).
MLSPACES_API Json ToJson(const RobotReport& report);

/// The report as readable text, one section per part, problems last; ends with a newline.
MLSPACES_API std::string FormatRobotReport(const RobotReport& report);

}  // namespace mlspaces::robots
