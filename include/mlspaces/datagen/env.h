// The datagen environment: one user scene + the robot + the scene's objects, composed and
// compiled once per scene (sim::Scene), then reset per episode without recompiling.
//
// The compiled model is shared and immutable (shared_ptr<const mjModel>); each Env owns its
// mjData (or shares both with their Python owners: ShareModelAndData). Reset() = mj_resetData + the
// robot's home pose (the model's custom numerics
// `<prefix>home_arm` / `<prefix>home_gripper`, arm servo targets set to it, gripper open) + the
// mocap base at the configured base pose + mj_forward.
//
// Lifetimes: model() and data() are never null. model() is valid while the Env lives
// (shared_model() keeps the model alive on its own); data() is owned by the Env. The
// references the accessors return are valid while the Env lives and not across a move.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/json.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/robots/insert.h"
#include "mlspaces/robots/robot_spec.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/scene.h"

namespace mlspaces::datagen {

// The robot layer's types under the names datagen code uses.
using robots::BaseKind;
using robots::RobotSpec;

/// franka_droid (RobotsDir(), or `source_dir`/assets/robots when given) under `prefix` at
/// `base`. @throws Error when its robot.yaml does not load.
MLSPACES_API RobotSpec FrankaDroidSpec(const std::filesystem::path& source_dir = {},
                                       const Pose& base = {}, std::string prefix = "robot_0/");

using robots::RobotsDir;

struct RobotConfig;
/// The RobotSpec a robot_config asks for: robot `name` (a bundled robot's name, or the path of
/// a robot.yaml or its folder, relative to `base_dir`), its MJCF replaced by robot_xml_path
/// when given, under robot_namespace, with init_qpos / init_qpos_noise_range (empty: the
/// robot's home and home noise), base_size and gravcomp, at the identity base pose (samplers
/// move it).
/// robot_files molmospaces takes the robot's MolmoSpaces description (RobotsDir()/<name>/
/// molmospaces.yaml) with its MJCF in <assets>/robots/<name>/, assets = ResolveAssetsDir(
/// `assets_dir`) (pass libraries.assets_dir).
/// @throws Error (field robot_config.<key>) for an unknown robot, a bad robot.yaml, a missing
/// file, MolmoSpaces' files not installed, or a home pose of the wrong length.
MLSPACES_API RobotSpec
RobotSpecFromConfig(const RobotConfig& config, const std::filesystem::path& base_dir = {},
                    const std::optional<std::filesystem::path>& assets_dir = {});

class MLSPACES_API Env {
 public:
  // ===========================================================================================
  // Construction

  /// Inserts the robot into `scene` (which may already hold inserted assets), compiles it once
  /// and resets. `scene_key` names the scene for seeding (e.g. its path as written in the
  /// config); it should not depend on where the checkout lives.
  /// @throws Error for compile errors, a robot without its home numerics or joints.
  static Env Create(sim::Scene scene, const RobotSpec& robot, std::string scene_key);
  /// Loads `scene_xml` (sim::Scene::Load) and calls Create; scene_key = the path as given.
  static Env Load(const std::filesystem::path& scene_xml, const RobotSpec& robot);

  Env(Env&&) noexcept = default;
  Env& operator=(Env&&) noexcept = default;

  // ===========================================================================================
  // Episodes

  /// Per-episode reset, no recompile: mj_resetData, robot home pose and servo targets,
  /// base mocap at robot().base, mj_forward. Every object returns to its compiled pose.
  void Reset();

  // ===========================================================================================
  // Bodies

  /// Body id. @throws Error naming the body when unknown.
  int BodyId(std::string_view name) const;
  /// True when the body's pose is state: a mocap body or a top-level body with a free joint.
  bool IsMovable(std::string_view name) const;
  /// World pose of a body: for movable bodies the state itself (mocap_pos/quat or free-joint
  /// qpos, exact), for others xpos/xquat of the last forward pass.
  /// @throws Error naming the body when unknown.
  Pose GetBodyPose(std::string_view name) const;
  /// Writes a movable body's pose into mocap_pos/quat or its free-joint qpos (quaternion
  /// normalised unless unit to 1e-12, free-joint velocity zeroed). Call ForwardPosition()
  /// before reading derived quantities.
  /// @throws Error naming the body when unknown, not movable, or a bad quaternion.
  void SetBodyPose(std::string_view name, const Pose& pose);

  /// The robot's base pose (its mocap body).
  /// The robot's base pose (robots::RobotBase: mocap state, holonomic joints, fixed pose).
  Pose GetRobotBasePose() const { return base_->Get(model_.get(), data_.get()); }
  /// @throws Error for a fixed base moved, or a holonomic base asked to leave its plane.
  void SetRobotBasePose(const Pose& pose) { base_->Set(model_.get(), data_.get(), pose); }

  // ===========================================================================================
  // Forward passes

  /// mj_fwdPosition (kinematics, collisions) / full mj_forward.
  void ForwardPosition();
  void Forward();

  // ===========================================================================================
  // Access (see the file comment for lifetimes)

  /// Hands the Env a model and data owned elsewhere, which it uses from now on: `model` must
  /// equal model() in every size (a copy of it, e.g. mj_copyModel), `data` must be made for
  /// it. The current state (mj_copyData) moves into `data`; the deleters run when the Env no
  /// longer needs them. The Python binding gives the Env the model and data of the user's
  /// `mujoco.MjModel` / `MjData` this way, so user code and the engine share them. Call it
  /// before anything else holds model() or data() (TaskSampler::PrepareEnv).
  /// @throws Error when a size differs.
  void ShareModelAndData(std::shared_ptr<const mjModel> model, std::shared_ptr<mjData> data);

  /// The compiled model: never null.
  const mjModel* model() const { return model_.get(); }
  std::shared_ptr<const mjModel> shared_model() const { return model_; }
  /// The Env's own mjData: never null.
  mjData* data() { return data_.get(); }
  const mjData* data() const { return data_.get(); }
  const RobotSpec& robot() const { return robot_; }
  /// `<prefix><base_body>`, e.g. "robot_0/base".
  const std::string& robot_base_body() const { return robot_base_body_; }
  const std::string& scene_key() const { return scene_key_; }
  /// The scene metadata (sim::Scene::metadata) of the composed scene.
  const Json& metadata() const { return metadata_; }
  /// The composed scene (robot inserted) that was compiled: what the grasp collision probe
  /// is built from.
  const sim::Scene& scene() const { return *scene_; }
  /// Home joint angles applied by Reset(): arm then gripper drivers.
  const std::vector<double>& home_qpos() const { return home_values_; }
  /// qpos addresses of the arm joints, in RobotSpec order.
  const std::vector<int>& arm_qpos_adr() const { return arm_qpos_adr_; }

 private:
  Env() = default;

  std::shared_ptr<const mjModel> model_;
  std::shared_ptr<const sim::Scene> scene_;
  std::shared_ptr<mjData> data_;
  RobotSpec robot_;
  std::string robot_base_body_;
  std::shared_ptr<const robots::RobotBase> base_;
  std::string scene_key_;
  Json metadata_;
  // Resolved once at creation.
  std::vector<int> home_qpos_adr_;  // arm joints then gripper joints
  std::vector<double> home_values_;
  std::vector<int> arm_qpos_adr_;
  std::vector<int> arm_actuators_;  // -1 when a joint has no actuator of its name
  std::vector<std::pair<int, int>> mirrored_qpos_adr_;  // follower, driver
};

}  // namespace mlspaces::datagen
