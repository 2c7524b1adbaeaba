// A robot as data: the strict loader of `robot.yaml` (docs/robots.md) and the RobotSpec the
// engine inserts, views and plans with.
//
// A robot is a folder holding `robot.yaml` and its MJCF. LoadRobotDescription reads the YAML
// strictly (unknown keys, wrong types and lengths, NaN: one line naming the file and the
// dotted field), then checks every name it lists against the MJCF compiled alone. MakeRobotSpec
// turns a description into the engine's RobotSpec under a name prefix. Bundled robots live in
// RobotsDir()/<name>/robot.yaml; FindRobot resolves a registered name or a path.
//
// Lifetimes: plain values, no references kept.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mlspaces/core/transform.h"

namespace mlspaces::robots {

// ---------------------------------------------------------------------------------------
// The description (what robot.yaml says).

/// How the robot's base is held: a mocap body (moved by writing its pose), planar x / y / yaw
/// joints driven by position servos (a holonomic mobile base), or a body fixed to the world.
enum class BaseKind { kMocap, kHolonomic, kFixed };

/// The YAML names of BaseKind, in declaration order (found by ADL by the YAML archive).
constexpr std::array<std::string_view, 3> kBaseKindNames{"mocap", "holonomic", "fixed"};
constexpr const auto& YamlEnumNames(BaseKind) { return kBaseKindNames; }

struct MLSPACES_API BaseDescription {
  BaseKind kind = BaseKind::kMocap;
  /// A top body of the MJCF that already is the base (a mocap body for kind mocap); null =
  /// mlspaces creates body `base` at insertion and attaches root_body under it.
  std::optional<std::string> body;

  template <class A>
  void Serialize(A* a) {
    a->Visit("kind", kind);
    a->Visit("body", body);
  }
};

struct MLSPACES_API ArmDescription {
  std::vector<std::string> joints;  ///< 1-dof hinge or slide joints, base to tip
  /// Position actuators, one per joint; null = actuators named like the joints.
  std::optional<std::vector<std::string>> actuators;
  std::vector<double> home;  ///< one per joint
  /// Uniform +- half-widths of the per-episode home noise; null = none.
  std::optional<std::vector<double>> home_noise;

  template <class A>
  void Serialize(A* a) {
    a->Visit("joints", joints);
    a->Visit("actuators", actuators);
    a->Visit("home", home);
    a->Visit("home_noise", home_noise);
  }
};

struct MLSPACES_API GripperDescription {
  std::string body;      ///< root body of the gripper subtree
  std::string actuator;  ///< the one gripper actuator
  double open_ctrl = 0;
  double closed_ctrl = 0;
  std::vector<std::string> joints;  ///< driver joints (recorded, reset to `home`)
  /// {follower, driver}: followers reset to minus their driver's angle.
  std::vector<std::array<std::string, 2>> mirrored;
  std::vector<double> home;                  ///< one per driver joint
  std::array<std::string, 2> finger_pads;    ///< two geoms; their distance is the finger gap
  std::array<double, 2> finger_range{0, 0};  ///< finger gap closed .. open, metres

  template <class A>
  void Serialize(A* a) {
    a->Visit("body", body);
    a->Visit("actuator", actuator);
    a->Visit("open_ctrl", open_ctrl);
    a->Visit("closed_ctrl", closed_ctrl);
    a->Visit("joints", joints);
    a->Visit("mirrored", mirrored);
    a->Visit("home", home);
    a->Visit("finger_pads", finger_pads);
    a->Visit("finger_range", finger_range);
  }
};

/// One camera of the robot's own camera system (camera_config.name: RobotCameraSystem).
struct MLSPACES_API RobotCamera {
  std::string name;
  std::string type = "mjcf";                  ///< "mjcf" or "robot_mounted"
  std::optional<std::string> mjcf_name;       ///< mjcf: the MJCF camera
  std::optional<std::string> reference_body;  ///< robot_mounted: the body it rides on
  std::array<double, 3> offset{0, 0, 0};
  std::array<double, 4> quaternion{1, 0, 0, 0};  ///< wxyz
  double fov = 45.0;                             ///< vertical, degrees

  template <class A>
  void Serialize(A* a) {
    a->Visit("name", name);
    a->Visit("type", type);
    a->Visit("mjcf_name", mjcf_name);
    a->Visit("reference_body", reference_body);
    a->Visit("offset", offset);
    a->Visit("quaternion", quaternion);
    a->Visit("fov", fov);
  }
};

struct MLSPACES_API RecordDescription {
  /// env_states/articulations/<articulation>; null = the robot's name.
  std::optional<std::string> articulation;
  /// Row width (arm q, gripper q, arm v, gripper v, zero-padded); null = 2 (arm + gripper).
  std::optional<size_t> articulation_width;

  template <class A>
  void Serialize(A* a) {
    a->Visit("articulation", articulation);
    a->Visit("articulation_width", articulation_width);
  }
};

/// robot.yaml. Names are MJCF names before the robot's prefix.
struct MLSPACES_API RobotDescription {
  std::string name;
  std::filesystem::path mjcf;  ///< absolute after loading
  std::string root_body;
  BaseDescription base;
  bool gravcomp = true;
  std::string tcp_site;
  ArmDescription arm;
  GripperDescription gripper;
  std::vector<RobotCamera> cameras;
  /// Names of franka_droid's model (as configs written for it use) -> this robot's names.
  std::map<std::string, std::string> aliases;
  RecordDescription record;

  // Set by LoadRobotDescription, not read from the YAML.
  std::filesystem::path file;  ///< the robot.yaml, absolute
  /// 16 hex digits: FNV-1a 64 of the XXH3-128 hashes (SourceFileHash) of robot.yaml and of the
  /// MJCF's source files (sim::AssetSourceFiles): recorded in
  /// every episode's provenance.
  std::string hash;

  template <class A>
  void Serialize(A* a) {
    a->Visit("name", name);
    a->Visit("mjcf", mjcf);
    a->Visit("root_body", root_body);
    a->Visit("base", base);
    a->Visit("gravcomp", gravcomp);
    a->Visit("tcp_site", tcp_site);
    a->Visit("arm", arm);
    a->Visit("gripper", gripper);
    a->Visit("cameras", cameras);
    a->Visit("aliases", aliases);
    a->Visit("record", record);
  }
};

/// Reads `file` (a robot.yaml, or a folder holding one) strictly, checks required fields,
/// lengths and finite numbers, and checks each listed name against the MJCF compiled alone
/// (the joints hinge/slide, the actuators, sites, bodies and geoms present).
/// A relative `mjcf` resolves against `mjcf_dir` when given (a description we ship for model
/// files installed elsewhere, e.g. MolmoSpaces' robots), else against the robot.yaml's folder.
/// @throws Error (path = the robot.yaml, field = the dotted key) for the first problem.
MLSPACES_API RobotDescription LoadRobotDescription(const std::filesystem::path& file,
                                                   const std::filesystem::path& mjcf_dir = {});

/// Every problem LoadRobotDescription would throw for, one line each ("<file>: <field>:
/// <problem>"), instead of the first: what `mlspaces inspect-robot` prints. Empty = valid.
/// `out` is filled as far as it could be read (nullopt when the YAML does not parse).
MLSPACES_API std::vector<std::string> CheckRobotDescription(
    const std::filesystem::path& file, std::optional<RobotDescription>* out = nullptr);

// ---------------------------------------------------------------------------------------
// Finding robots.

/// Where bundled robots live: $MLSPACES_ROBOTS_DIR when set, else the source tree's
/// assets/robots, else the installed package's <prefix>/share/mlspaces/robots.
MLSPACES_API std::filesystem::path RobotsDir();

/// Where robots are found by name, in order: the folders of $MLSPACES_ROBOT_PATH
/// (':'-separated; the user's robots, each a folder <name>/robot.yaml), then RobotsDir().
MLSPACES_API std::vector<std::filesystem::path> RobotSearchPath();

/// The names of the robots on RobotSearchPath() (folders holding a robot.yaml), sorted, each
/// once.
MLSPACES_API std::vector<std::string> BundledRobots();

/// The robot.yaml that `name_or_path` means: a path (it holds a '/' or ends in .yaml; a
/// relative one resolves against `base_dir`) to a robot.yaml or its folder, else the robot of
/// that name in the first folder of RobotSearchPath() that has it. @throws Error naming the field
/// `field` for an unknown robot (with the bundled names and a "did you mean") or a path that holds
/// no robot.yaml.
MLSPACES_API std::filesystem::path FindRobot(std::string_view name_or_path,
                                             const std::filesystem::path& base_dir = {},
                                             const std::string& field = "robot_config.name");

// ---------------------------------------------------------------------------------------
// The engine's form.

/// A robot ready to insert: its description's names, plus the prefix, the base pose and the
/// per-run overrides (home pose, pedestal, gravcomp).
struct MLSPACES_API RobotSpec {
  std::string name = "franka_droid";
  std::filesystem::path xml;  ///< the MJCF
  std::filesystem::path description_file;
  std::string description_hash;
  std::string prefix = "robot_0/";
  /// The base pose of every episode after Reset().
  Pose base;
  BaseKind base_kind = BaseKind::kMocap;
  /// True when the MJCF holds the base body itself (description base.body); else insertion
  /// creates it.
  bool base_in_model = true;
  /// The top base body (after the prefix).
  std::string base_body = "base";
  /// Arm joints (after the prefix); `arm_actuators` their position servos, in the same order.
  std::vector<std::string> arm_joints;
  std::vector<std::string> arm_actuators;
  /// Gripper driver joints (after the prefix), in the order of `home_gripper`.
  std::vector<std::string> gripper_joints;
  /// Joints held at minus a driver's angle: {follower, driver} (after prefix).
  std::vector<std::pair<std::string, std::string>> mirrored_joints;
  /// Home angles applied by Reset(): arm, then gripper drivers.
  std::vector<double> home_arm, home_gripper;
  /// Per-episode uniform +- noise on the arm's home angles (empty = none).
  std::vector<double> home_noise;
  /// A box pedestal of this full size (x, y, z) in the base body, standing on the base frame,
  /// with the arm root mounted on its top. The base pose stays the floor pose; nullopt = none.
  std::optional<std::array<double, 3>> pedestal_size;
  /// MuJoCo's body gravcomp is 1 on every body of the arm root's subtree, else 0 there.
  bool gravcomp = true;

  /// Root body of the arm (its subtree gets gravity compensation, see `gravcomp`).
  std::string arm_root_body = "fr3_link0";
  /// Root body of the gripper subtree (grasp state, the collision probe).
  std::string gripper_body = "gripper/base";
  /// The gripper's one actuator: ctrl gripper_open_ctrl = open .. gripper_closed_ctrl = closed.
  std::string gripper_actuator = "gripper/fingers_actuator";
  double gripper_open_ctrl = 0;
  double gripper_closed_ctrl = 255;
  /// The TCP site (+z approach, fingers along +-y).
  std::string tcp_site = "gripper/grasp_site";
  /// The two finger pad geoms whose gap is the inter-finger distance.
  std::array<std::string, 2> finger_pads = {"gripper/left_pad2", "gripper/right_pad2"};
  /// Finger gap closed .. open (metres).
  std::array<double, 2> finger_range{0.0, 0.087};
  /// The recorded articulation name (env_states/articulations/<name>) and its row width.
  std::string articulation_name = "panda";
  size_t articulation_width = 31;
  /// franka_droid names -> this robot's (before the prefix); see RobotDescription::aliases.
  std::map<std::string, std::string> aliases;
  /// The robot's own cameras (RobotDescription::cameras).
  std::vector<RobotCamera> cameras;

  /// `name` with a franka_droid alias applied (names without an alias come back unchanged);
  /// `name` is before the prefix.
  std::string Resolve(const std::string& name) const;
};

/// The spec of `description` under `prefix` at the identity base pose, with its home pose,
/// home noise and gravcomp, without a pedestal (robot_config.base_size sets one).
MLSPACES_API RobotSpec MakeRobotSpec(const RobotDescription& description,
                                     std::string prefix = "robot_0/");

/// MakeRobotSpec(LoadRobotDescription(FindRobot(name_or_path))).
MLSPACES_API RobotSpec LoadRobotSpec(std::string_view name_or_path,
                                     std::string prefix = "robot_0/");

}  // namespace mlspaces::robots
