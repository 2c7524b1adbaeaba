// Datagen job configs: plain structs of the experiment config (the top level and its task,
// task sampler, robot, camera and policy sub-configs), loaded strictly from YAML, overridden
// with `--set a.b=v`, dumped as canonical YAML, hashed, and registered by name. Fields, their
// defaults and where they come from: docs/config.md.
//
// Every struct has defaulted members and one `Serialize(Archive*)` member listing its fields;
// the same description drives loading, `--set`, dumping, hashing and path resolution.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mlspaces/library/library_config.h"
#include "mlspaces/library/license_policy.h"

namespace mlspaces::datagen {

// ---------------------------------------------------------------------------------------
// Enums. Each has a name table (EnumNames below); YAML uses the names.

enum class TaskType {
  kPick,
  kOpen,
  kClose,
  kPickAndPlace,
  kPickAndPlaceNextTo,
  kPickAndPlaceColor
};
enum class SceneDataset { kUser };
enum class LogLevel { kDebug, kInfo, kWarning, kError };
enum class ActionDtype { kFloat32, kFloat64 };
enum class ArmCommandMode { kJointPosition, kJointRelPosition };
enum class GripperCommandMode { kJointPosition };
enum class CameraType { kMjcf, kRobotMounted };
enum class RobotFiles { kBundled, kMolmoSpaces };

/// The YAML names of an enum's values, in declaration order.
template <class E>
struct EnumNames;
template <>
struct EnumNames<TaskType> {
  static constexpr std::array<std::string_view, 6> kNames{
      "pick", "open", "close", "pick_and_place", "pick_and_place_next_to", "pick_and_place_color"};
};
template <>
struct EnumNames<SceneDataset> {
  static constexpr std::array<std::string_view, 1> kNames{"user"};
};
template <>
struct EnumNames<LogLevel> {
  static constexpr std::array<std::string_view, 4> kNames{"debug", "info", "warning", "error"};
};
template <>
struct EnumNames<ActionDtype> {
  static constexpr std::array<std::string_view, 2> kNames{"float32", "float64"};
};
template <>
struct EnumNames<ArmCommandMode> {
  static constexpr std::array<std::string_view, 2> kNames{"joint_position", "joint_rel_position"};
};
template <>
struct EnumNames<GripperCommandMode> {
  static constexpr std::array<std::string_view, 1> kNames{"joint_position"};
};
template <>
struct EnumNames<CameraType> {
  static constexpr std::array<std::string_view, 2> kNames{"mjcf", "robot_mounted"};
};
template <>
struct EnumNames<RobotFiles> {
  static constexpr std::array<std::string_view, 2> kNames{"bundled", "molmospaces"};
};

/// The YAML name of an enum value.
template <class E>
std::string_view EnumName(E value) {
  return EnumNames<E>::kNames[static_cast<size_t>(value)];
}

/// The YAML archive's enum hook (core/yaml_archive.h), found by ADL.
template <class E>
requires requires { EnumNames<E>::kNames; }
constexpr const auto& YamlEnumNames(E) { return EnumNames<E>::kNames; }

// ---------------------------------------------------------------------------------------
// Sub-configs.

/// PickTaskConfig: presets for what the task sampler fills per episode. A preset
/// `pickup_obj_name` is honoured; the three poses are written by the sampler every episode
/// (7-vectors: xyz + quaternion wxyz, world frame).
struct MLSPACES_API TaskConfig {
  TaskType task_cls = TaskType::kPick;
  std::optional<std::string> pickup_obj_name;
  std::optional<std::array<double, 7>> robot_base_pose;
  std::optional<std::array<double, 7>> pickup_obj_start_pose;
  std::optional<std::array<double, 7>> pickup_obj_goal_pose;
  std::optional<std::string> receptacle_name;
  /// Objects inserted into the scene at runtime: body name -> MJCF file.
  std::map<std::string, std::filesystem::path> added_objects;
  bool use_sensors = true;
  ActionDtype action_dtype = ActionDtype::kFloat32;
  double succ_pos_threshold = 0.01;  ///< metres
  bool enable_rendering = true;
  // open / close (docs/tasks.md): a preset joint (MJCF name; null = sampled), the success
  // threshold on the opened fraction (null = 0.15 open, 0.85 close), and the original's
  // any_inst_of_category (accepted; success is judged on the chosen joint only).
  std::optional<std::string> joint_name;
  std::optional<double> task_success_threshold;
  bool any_inst_of_category = false;
  // pick_and_place* (docs/tasks.md): a preset receptacle (body name; null = sampled), the
  // support weight fraction, the receptacle's allowed displacement (m) and tilt (rad), the
  // "next to" surface gap band (m).
  std::optional<std::string> place_receptacle_name;
  double receptacle_supported_weight_frac = 0.5;
  double max_place_receptacle_pos_displacement = 0.1;
  double max_place_receptacle_rot_displacement = 0.7853981633974483;
  double min_surface_to_surface_gap = 0.0;
  double max_surface_to_surface_gap = 0.05;

  template <class A>
  void Serialize(A* a) {
    a->Visit("task_cls", task_cls);
    a->Visit("pickup_obj_name", pickup_obj_name);
    a->Visit("robot_base_pose", robot_base_pose);
    a->Visit("pickup_obj_start_pose", pickup_obj_start_pose);
    a->Visit("pickup_obj_goal_pose", pickup_obj_goal_pose);
    a->Visit("receptacle_name", receptacle_name);
    a->Visit("added_objects", added_objects);
    a->Visit("use_sensors", use_sensors);
    a->Visit("action_dtype", action_dtype);
    a->Visit("succ_pos_threshold", succ_pos_threshold);
    a->Visit("enable_rendering", enable_rendering);
    a->Visit("joint_name", joint_name);
    a->Visit("task_success_threshold", task_success_threshold);
    a->Visit("any_inst_of_category", any_inst_of_category);
    a->Visit("place_receptacle_name", place_receptacle_name);
    a->Visit("receptacle_supported_weight_frac", receptacle_supported_weight_frac);
    a->Visit("max_place_receptacle_pos_displacement", max_place_receptacle_pos_displacement);
    a->Visit("max_place_receptacle_rot_displacement", max_place_receptacle_rot_displacement);
    a->Visit("min_surface_to_surface_gap", min_surface_to_surface_gap);
    a->Visit("max_surface_to_surface_gap", max_surface_to_surface_gap);
  }
};

/// Uniform planar noise U(-x, x), U(-y, y) metres and U(-yaw_deg, yaw_deg) degrees, composed
/// in the frame of the thing it moves (the tutorial's `random_pose`).
struct MLSPACES_API PlanarNoise {
  double x = 0.0;
  double y = 0.0;
  double yaw_deg = 0.0;

  template <class A>
  void Serialize(A* a) {
    a->Visit("x", x);
    a->Visit("y", y);
    a->Visit("yaw_deg", yaw_deg);
  }
};

/// PickTaskSamplerConfig, plus the parameters of the built-in config-driven sampler
/// `block_pickup`, which reproduces the tutorial's BlockPickupTaskSampler with no code.
struct MLSPACES_API TaskSamplerConfig {
  /// A task sampler registered by name; "block_pickup" is built in.
  std::string task_sampler_class = "block_pickup";
  SceneDataset dataset_name = SceneDataset::kUser;
  /// The user scenes (relative paths resolve against the YAML file's folder).
  std::vector<std::filesystem::path> scene_xml_paths;
  /// Which scenes to run (indices into scene_xml_paths); null = all.
  std::optional<std::vector<int64_t>> house_inds;
  int64_t samples_per_house = 1;
  std::string house_variant = "base";
  int64_t episodes_per_batch = 4;
  int64_t task_batch_size = 1;
  std::optional<int64_t> max_tasks;  ///< null = no limit
  int64_t sim_settle_timesteps = 500;
  int64_t max_allowed_sequential_task_sampler_failures = 10;
  int64_t max_allowed_sequential_rollout_failures = 10;
  int64_t max_allowed_sequential_irrecoverable_failures = 5;
  int64_t max_total_attempts_multiplier = 6;
  int64_t max_asset_failures = 10;
  std::vector<std::string> pickup_types;  ///< empty = any type
  bool filter_for_grasps = true;
  std::optional<std::vector<std::string>> grasp_libraries;  ///< null = all
  // block_pickup: the robot base and the object move by these noises, goal = start + z.
  PlanarNoise robot_base_noise{0.1, 0.1, 30.0};
  PlanarNoise object_noise{0.05, 0.05, 45.0};
  double goal_offset_z = 0.05;  ///< metres
  /// open / close: the joint's initial opened fraction (null = 0 open, 0.5 close).
  std::optional<double> target_initial_state_open_percentage;
  // pick_and_place*: receptacle assets (categories; empty = any annotated receptacle), how
  // many are added to the scene, episodes per receptacle, the object-receptacle distance band
  // (m), the robot-receptacle distance limit (m), placement tries.
  std::vector<std::string> place_receptacle_types;
  int64_t num_place_receptacles = 3;
  int64_t episodes_per_receptacle = 2;
  double min_object_to_receptacle_dist = 0.15;
  double max_object_to_receptacle_dist = 0.5;
  double max_robot_to_place_receptacle_dist = 0.7;
  int64_t max_place_receptacle_sampling_attempts = 100;

  template <class A>
  void Serialize(A* a) {
    a->Visit("task_sampler_class", task_sampler_class);
    a->Visit("dataset_name", dataset_name);
    a->Visit("scene_xml_paths", scene_xml_paths);
    a->Visit("house_inds", house_inds);
    a->Visit("samples_per_house", samples_per_house);
    a->Visit("house_variant", house_variant);
    a->Visit("episodes_per_batch", episodes_per_batch);
    a->Visit("task_batch_size", task_batch_size);
    a->Visit("max_tasks", max_tasks);
    a->Visit("sim_settle_timesteps", sim_settle_timesteps);
    a->Visit("max_allowed_sequential_task_sampler_failures",
             max_allowed_sequential_task_sampler_failures);
    a->Visit("max_allowed_sequential_rollout_failures", max_allowed_sequential_rollout_failures);
    a->Visit("max_allowed_sequential_irrecoverable_failures",
             max_allowed_sequential_irrecoverable_failures);
    a->Visit("max_total_attempts_multiplier", max_total_attempts_multiplier);
    a->Visit("max_asset_failures", max_asset_failures);
    a->Visit("pickup_types", pickup_types);
    a->Visit("filter_for_grasps", filter_for_grasps);
    a->Visit("grasp_libraries", grasp_libraries);
    a->Visit("robot_base_noise", robot_base_noise);
    a->Visit("object_noise", object_noise);
    a->Visit("goal_offset_z", goal_offset_z);
    a->Visit("target_initial_state_open_percentage", target_initial_state_open_percentage);
    a->Visit("place_receptacle_types", place_receptacle_types);
    a->Visit("num_place_receptacles", num_place_receptacles);
    a->Visit("episodes_per_receptacle", episodes_per_receptacle);
    a->Visit("min_object_to_receptacle_dist", min_object_to_receptacle_dist);
    a->Visit("max_object_to_receptacle_dist", max_object_to_receptacle_dist);
    a->Visit("max_robot_to_place_receptacle_dist", max_robot_to_place_receptacle_dist);
    a->Visit("max_place_receptacle_sampling_attempts", max_place_receptacle_sampling_attempts);
  }
};

/// The home pose (radians / metres), one value per joint; empty = the robot's own (robot.yaml
/// arm.home / gripper.home).
struct MLSPACES_API InitQpos {
  std::vector<double> arm;
  std::vector<double> gripper;

  template <class A>
  void Serialize(A* a) {
    a->Visit("arm", arm);
    a->Visit("gripper", gripper);
  }
};

/// Uniform +- noise on the initial joint positions, radians (gripper exact); empty = the
/// robot's own (robot.yaml arm.home_noise).
struct MLSPACES_API InitQposNoise {
  std::vector<double> arm;

  template <class A>
  void Serialize(A* a) {
    a->Visit("arm", arm);
  }
};

struct MLSPACES_API CommandMode {
  ArmCommandMode arm = ArmCommandMode::kJointPosition;
  GripperCommandMode gripper = GripperCommandMode::kJointPosition;

  template <class A>
  void Serialize(A* a) {
    a->Visit("arm", arm);
    a->Visit("gripper", gripper);
  }
};

/// Task-space action noise (datagen/action_noise.h); enabled by default.
struct MLSPACES_API ActionNoiseConfig {
  bool enabled = true;
  double action_scale_factor = 0.1;
  double rotation_noise_scale = 0.1;
  double max_tcp_position_noise = 0.02;  ///< metres
  double max_tcp_rotation_noise = 0.1;   ///< radians

  template <class A>
  void Serialize(A* a) {
    a->Visit("enabled", enabled);
    a->Visit("action_scale_factor", action_scale_factor);
    a->Visit("rotation_noise_scale", rotation_noise_scale);
    a->Visit("max_tcp_position_noise", max_tcp_position_noise);
    a->Visit("max_tcp_rotation_noise", max_tcp_rotation_noise);
  }
};

/// FrankaRobotConfig / BaseRobotConfig: which robot (docs/robots.md) and its per-run settings.
struct MLSPACES_API RobotConfig {
  /// A bundled robot's name (`mlspaces inspect-robot --list`), or the path of a robot.yaml or
  /// its folder.
  std::string name = "franka_droid";
  /// A folder holding the robot's robot.yaml (relative: to the config file); null = `name`.
  std::optional<std::filesystem::path> robot_dir;
  /// Whose model files: `bundled` (ours, assets/robots/<name>/robot.yaml) or `molmospaces`
  /// (MolmoSpaces' installed <assets>/robots/<name>/, described by our
  /// assets/robots/<name>/molmospaces.yaml; docs/robots.md).
  RobotFiles robot_files = RobotFiles::kBundled;
  std::string robot_namespace = "robot_0/";
  /// The robot's MJCF; null = the built-in model of `name` (assets/robots/<name>/).
  std::optional<std::filesystem::path> robot_xml_path;
  /// Pedestal size (x, y, z) in metres; null = no pedestal.
  std::optional<std::array<double, 3>> base_size = std::array<double, 3>{0.5, 0.5, 0.58};
  InitQpos init_qpos;
  InitQposNoise init_qpos_noise_range;
  CommandMode command_mode;
  bool gravcomp = true;
  ActionNoiseConfig action_noise_config;

  template <class A>
  void Serialize(A* a) {
    a->Visit("name", name);
    a->Visit("robot_dir", robot_dir);
    a->Visit("robot_files", robot_files);
    a->Visit("robot_namespace", robot_namespace);
    a->Visit("robot_xml_path", robot_xml_path);
    a->Visit("base_size", base_size);
    a->Visit("init_qpos", init_qpos);
    a->Visit("init_qpos_noise_range", init_qpos_noise_range);
    a->Visit("command_mode", command_mode);
    a->Visit("gravcomp", gravcomp);
    a->Visit("action_noise_config", action_noise_config);
  }
};

/// One camera of a camera system. `mjcf`: an MJCF camera of the robot (`mjcf_name` under
/// `robot_namespace`). `robot_mounted`: a camera at `camera_offset` / `camera_quaternion`
/// (wxyz) in the frame of the first of `reference_body_names`.
struct MLSPACES_API CameraConfig {
  std::string name;
  CameraType type = CameraType::kMjcf;
  std::string mjcf_name;                                        ///< mjcf only
  std::string robot_namespace;                                  ///< mjcf only
  std::vector<std::string> reference_body_names;                ///< robot_mounted only
  std::array<double, 3> camera_offset{0.0, 0.0, 0.0};           ///< robot_mounted only
  std::array<double, 4> camera_quaternion{1.0, 0.0, 0.0, 0.0};  ///< robot_mounted only
  double fov = 45.0;                                            ///< vertical field of view, degrees
  /// Minimum visible fraction per object name (robot placement checks).
  std::map<std::string, double> visibility_constraints;
  /// object_image_points of this camera from the whole segmentation mask, not eroded (the
  /// original's option for wide-angle cameras).
  bool skip_erosion = false;

  template <class A>
  void Serialize(A* a) {
    a->Visit("name", name);
    a->Visit("type", type);
    a->Visit("mjcf_name", mjcf_name);
    a->Visit("robot_namespace", robot_namespace);
    a->Visit("reference_body_names", reference_body_names);
    a->Visit("camera_offset", camera_offset);
    a->Visit("camera_quaternion", camera_quaternion);
    a->Visit("fov", fov);
    a->Visit("visibility_constraints", visibility_constraints);
    a->Visit("skip_erosion", skip_erosion);
  }
};

/// A camera system; the defaults are FrankaDroidCameraSystem.
struct MLSPACES_API CameraSystemConfig {
  std::string name = "FrankaDroidCameraSystem";     ///< informational
  std::array<int64_t, 2> img_resolution{640, 368};  ///< width, height
  std::vector<CameraConfig> cameras = DroidCameras();
  /// Also write a depth video per camera (episode_<k>_<cam>_depth_batch_...mp4): metric
  /// depth mapped linearly from [0, depth_max_m] to grey 0..255 (farther is clipped).
  bool record_depth = false;
  double depth_max_m = 3.0;
  /// H.264 encoding of the videos: x264 constant rate factor (0-51) and preset.
  int64_t video_crf = 25;
  std::string video_preset = "veryfast";
  /// MuJoCo's shadows and floor reflections (on by default, as the original's).
  bool shadows = true;
  bool reflections = true;
  /// Shadow-map side in texels (0: the scene's vis.quality.shadowsize, 4096 unless it sets
  /// one), offscreen multisampling (-1: the scene's offsamples, 4 unless set; 0: off) and
  /// shadow maps fitted each frame to the casters whose shadows the state's cameras see
  /// (sim::FitShadowMaps: the same shadows with smaller texels). The defaults render several times
  /// faster than the original's settings at mean SSIM >= 0.97 against them (docs/sim.md, "Render
  /// speed and quality"); `shadow_size: 0, multisamples: -1, fit_shadows: false` renders as the
  /// original does.
  int64_t shadow_size = 1024;
  int64_t multisamples = 0;
  bool fit_shadows = true;
  /// Shadows in one pass (sim::RenderOptions::one_pass_shadows): each shadow light's map
  /// drawn once per state for all cameras, and lit in the same pass as the other lights;
  /// the same pictures as MuJoCo's passes (false) for about half the cost.
  bool one_pass_shadows = true;
  /// With one pass: cylinders, capsule sides and boxes in fewer pieces along their straight
  /// sides where the lighting allows (sim::RenderOptions::coarse_sides): the same pixels
  /// covered, about a fifth less time a frame on llvmpipe; false draws MuJoCo's shapes.
  bool coarse_sides = true;
  /// With one pass: the geoms' textures sampled from their nearest mipmap level
  /// (sim::RenderOptions::nearest_mipmap), not MuJoCo's two blended: about 8% less a
  /// frame of the tutorial on llvmpipe (its floor is textured); false samples as MuJoCo.
  bool nearest_mipmap = true;
  /// Record obs/extra/object_image_points (datagen/object_image_points.h), as the original
  /// always does: the tracked objects drawn again over each camera's frame.
  bool object_image_points = true;

  /// FrankaDroidCameraSystem's two cameras: wrist_camera and exo_camera_1.
  static std::vector<CameraConfig> DroidCameras();

  template <class A>
  void Serialize(A* a) {
    a->Visit("name", name);
    a->Visit("img_resolution", img_resolution);
    a->Visit("cameras", cameras);
    a->Visit("record_depth", record_depth);
    a->Visit("depth_max_m", depth_max_m);
    a->Visit("video_crf", video_crf);
    a->Visit("video_preset", video_preset);
    a->Visit("shadows", shadows);
    a->Visit("reflections", reflections);
    a->Visit("shadow_size", shadow_size);
    a->Visit("multisamples", multisamples);
    a->Visit("fit_shadows", fit_shadows);
    a->Visit("one_pass_shadows", one_pass_shadows);
    a->Visit("coarse_sides", coarse_sides);
    a->Visit("nearest_mipmap", nearest_mipmap);
    a->Visit("object_image_points", object_image_points);
  }
};

/// The grasp ranking cost weights (rot is per degree).
struct MLSPACES_API GraspCostConfig {
  double pos = 1.0;
  double rot = 0.01;
  double vertical = 2.0;
  double com_dist = 8.0;

  template <class A>
  void Serialize(A* a) {
    a->Visit("pos", pos);
    a->Visit("rot", rot);
    a->Visit("vertical", vertical);
    a->Visit("com_dist", com_dist);
  }
};

/// PickPlannerPolicyConfig. Lengths in metres, speeds in m/s, durations in seconds.
struct MLSPACES_API PolicyConfig {
  std::string policy_cls = "pick_planner";
  double pregrasp_z_offset = 0.04;
  double postgrasp_z_offset = 0.08;
  double place_z_offset = 0.07;  ///< pick_and_place*: travel height above the target
  double end_z_offset = 0.05;    ///< pick_and_place*: retreat after the release
  double speed_slow = 0.08;
  double speed_fast = 0.20;
  double move_settle_time = 0.1;
  double gripper_close_duration = 0.5;
  double gripper_open_duration = 0.25;
  int64_t max_retries = 3;
  double gripper_empty_threshold = 0.002;
  double phase_timeout = 10.0;
  int64_t max_sequential_ik_failures = 8;
  double tcp_pos_err_threshold = 0.1;
  double tcp_rot_err_threshold = 30.0;  ///< degrees
  bool filter_colliding_grasps = true;
  int64_t grasp_collision_batch_size = 128;
  int64_t grasp_collision_max_grasps = 512;
  double grasp_width = 0.08;
  double grasp_length = 0.05;
  double grasp_height = 0.01;
  std::array<double, 3> grasp_base_pos{0.0, 0.0, -0.04};  ///< TCP frame
  GraspCostConfig grasp_cost_weights;
  double grasp_horizontal_cost_weight = 0.0;  ///< G[2,2]^2 weight (open / close only)
  bool filter_feasible_grasps = true;
  int64_t grasp_feasibility_batch_size = 256;
  int64_t grasp_feasibility_max_grasps = 256;
  std::optional<std::vector<std::string>> grasp_libraries;  ///< null = all

  template <class A>
  void Serialize(A* a) {
    a->Visit("policy_cls", policy_cls);
    a->Visit("pregrasp_z_offset", pregrasp_z_offset);
    a->Visit("postgrasp_z_offset", postgrasp_z_offset);
    a->Visit("place_z_offset", place_z_offset);
    a->Visit("end_z_offset", end_z_offset);
    a->Visit("speed_slow", speed_slow);
    a->Visit("speed_fast", speed_fast);
    a->Visit("move_settle_time", move_settle_time);
    a->Visit("gripper_close_duration", gripper_close_duration);
    a->Visit("gripper_open_duration", gripper_open_duration);
    a->Visit("max_retries", max_retries);
    a->Visit("gripper_empty_threshold", gripper_empty_threshold);
    a->Visit("phase_timeout", phase_timeout);
    a->Visit("max_sequential_ik_failures", max_sequential_ik_failures);
    a->Visit("tcp_pos_err_threshold", tcp_pos_err_threshold);
    a->Visit("tcp_rot_err_threshold", tcp_rot_err_threshold);
    a->Visit("filter_colliding_grasps", filter_colliding_grasps);
    a->Visit("grasp_collision_batch_size", grasp_collision_batch_size);
    a->Visit("grasp_collision_max_grasps", grasp_collision_max_grasps);
    a->Visit("grasp_width", grasp_width);
    a->Visit("grasp_length", grasp_length);
    a->Visit("grasp_height", grasp_height);
    a->Visit("grasp_base_pos", grasp_base_pos);
    a->Visit("grasp_cost_weights", grasp_cost_weights);
    a->Visit("grasp_horizontal_cost_weight", grasp_horizontal_cost_weight);
    a->Visit("filter_feasible_grasps", filter_feasible_grasps);
    a->Visit("grasp_feasibility_batch_size", grasp_feasibility_batch_size);
    a->Visit("grasp_feasibility_max_grasps", grasp_feasibility_max_grasps);
    a->Visit("grasp_libraries", grasp_libraries);
  }
};

// ---------------------------------------------------------------------------------------
// The experiment config.

/// The whole job config, with PickBaseConfig's defaults. `libraries`: the asset and grasp
/// libraries to register (library's LibraryConfig).
struct MLSPACES_API ExperimentConfig {
  int64_t num_envs = 1;
  int64_t num_workers = 1;
  TaskType task_type = TaskType::kPick;
  double policy_dt_ms = 66.0;
  double ctrl_dt_ms = 2.0;
  double sim_dt_ms = 2.0;
  std::optional<uint64_t> seed;  ///< null = drawn at run time
  int64_t task_horizon = 500;    ///< policy steps
  bool end_on_success = false;
  SceneDataset scene_dataset = SceneDataset::kUser;
  std::string data_split = "train";
  std::optional<std::filesystem::path> output_dir;
  bool filter_for_successful_trajectories = true;
  bool profile = true;
  LogLevel log_level = LogLevel::kInfo;
  std::string tag = "franka_pick_datagen";
  LibraryConfig libraries;
  /// Which assets a run may use (library/license_policy.h, docs/licenses.md): "all" or
  /// "commercial_safe" (no by-nc / by-nc-sa asset in the UID pools or the episodes' scenes).
  /// null = a resumed run's recorded policy, else MLSPACES_LICENSE_POLICY (then recorded in
  /// config.yaml when it is not "all"), else "all". `mlspaces datagen --license-policy` sets it.
  std::optional<LicensePolicy> license_policy;
  TaskConfig task_config;
  TaskSamplerConfig task_sampler_config;
  RobotConfig robot_config;
  CameraSystemConfig camera_config;
  PolicyConfig policy_config;

  /// Frames per second of the recorded data: 1000 / policy_dt_ms.
  double fps() const { return 1000.0 / policy_dt_ms; }

  template <class A>
  void Serialize(A* a) {
    a->Visit("num_envs", num_envs);
    a->Visit("num_workers", num_workers);
    a->Visit("task_type", task_type);
    a->Visit("policy_dt_ms", policy_dt_ms);
    a->Visit("ctrl_dt_ms", ctrl_dt_ms);
    a->Visit("sim_dt_ms", sim_dt_ms);
    a->Visit("seed", seed);
    a->Visit("task_horizon", task_horizon);
    a->Visit("end_on_success", end_on_success);
    a->Visit("scene_dataset", scene_dataset);
    a->Visit("data_split", data_split);
    a->Visit("output_dir", output_dir);
    a->Visit("filter_for_successful_trajectories", filter_for_successful_trajectories);
    a->Visit("profile", profile);
    a->Visit("log_level", log_level);
    a->Visit("tag", tag);
    a->Visit("libraries", libraries);
    a->Visit("license_policy", license_policy);
    a->Visit("task_config", task_config);
    a->Visit("task_sampler_config", task_sampler_config);
    a->Visit("robot_config", robot_config);
    a->Visit("camera_config", camera_config);
    a->Visit("policy_config", policy_config);
  }
};

// ---------------------------------------------------------------------------------------
// Named configs.

using ConfigFactory = std::function<ExperimentConfig()>;

/// Configs by name. A value, not a process global: register explicitly (no
/// static-initialisation self-registration). Names are matched case-insensitively.
class MLSPACES_API ConfigRegistry {
 public:
  /// A registry with the built-in configs: "PickBaseConfig" (the defaults) and
  /// "CustomAssetsDataGenConfig" (the tutorial's config).
  static ConfigRegistry WithBuiltins();

  /// Adds `name`. @throws UsageError if the name is empty, contains whitespace or is already
  /// registered (case-insensitively) and `replace` is false.
  void RegisterConfig(const std::string& name, ConfigFactory factory, bool replace = false);
  bool Contains(std::string_view name) const;
  /// A fresh config from the factory of `name`. @throws Error naming the closest names
  /// ("did you mean ...") and listing every registered one.
  ExperimentConfig Make(std::string_view name) const;
  /// The registered name spelled as registered; valid until the next RegisterConfig or the
  /// registry's end. @throws Error as Make.
  const std::string& CanonicalName(std::string_view name) const;
  /// Registered names in registration order.
  std::vector<std::string> Names() const;

 private:
  std::vector<std::pair<std::string, ConfigFactory>> entries_;
};

/// The tutorial's config (`CustomAssetsDataGenConfig`); relative paths (scene.xml,
/// asset_library) are relative to the project folder.
MLSPACES_API ExperimentConfig CustomAssetsDataGenConfig();

// ---------------------------------------------------------------------------------------
// Loading, overriding, dumping, hashing.

/// Loads a YAML config file strictly. The file may start from a registered config with a
/// top-level `base: NAME` (default: the defaults, "PickBaseConfig"); its keys then
/// override that config: mappings merge key by key, sequences and scalars replace, null
/// clears an optional. Relative paths (in the file and left relative by the base) resolve
/// against the file's folder. `libraries` is a LibraryConfig mapping or the path of a
/// libraries YAML file. Does not validate (see Validate).
/// @throws Error with the file, "line N" and the dotted key path for bad YAML, unknown keys
/// (with "did you mean"), wrong types and bad enum values.
MLSPACES_API ExperimentConfig LoadConfigFile(const std::filesystem::path& file,
                                             const ConfigRegistry& registry);

/// As LoadConfigFile, from YAML (or JSON) text: `origin` names it in errors and relative paths
/// resolve against `base_dir` (the Python binding hands its config objects over this way).
MLSPACES_API ExperimentConfig ParseConfigText(std::string_view text, const std::string& origin,
                                              const std::filesystem::path& base_dir,
                                              const ConfigRegistry& registry);

/// Applies one "a.b.c=VALUE" override: VALUE is parsed as YAML (scalar, [sequence] or
/// {mapping}) and applied to the dotted key with the loader's strictness; relative paths
/// resolve against `base_dir`. @throws UsageError naming the key.
MLSPACES_API void ApplyOverride(ExperimentConfig& config, std::string_view assignment,
                                const std::filesystem::path& base_dir);

/// Cross-field checks (time steps divide, counts positive, indices in range, camera fields
/// match their type, ...). @throws Error whose message starts with the dotted key path;
/// `origin` (may be empty) is used as the error's file.
MLSPACES_API void Validate(const ExperimentConfig& config,
                           const std::filesystem::path& origin = {});

/// Makes every relative path absolute against `base_dir` (lexically normalised).
MLSPACES_API void ResolvePaths(ExperimentConfig& config, const std::filesystem::path& base_dir);

/// The canonical YAML dump: every field in declaration order, numbers in shortest
/// round-trip form. LoadConfigFile(dump) gives back an equal config.
MLSPACES_API std::string DumpConfig(const ExperimentConfig& config);

/// A stable 64-bit hash of the config: FNV-1a 64 (mlspaces::HashString) of DumpConfig.
MLSPACES_API uint64_t ConfigHash(const ExperimentConfig& config);
/// ConfigHash as 16 lowercase hex digits.
MLSPACES_API std::string ConfigHashHex(const ExperimentConfig& config);

/// The hash of what shapes the data: ConfigHashHex of the config with the fields that only
/// say where output goes and how a run is carried out (output_dir, log_level, num_workers,
/// profile, libraries.assets_dir) reset to their defaults and every other path replaced by
/// what it holds: a file by its bytes (a scene XML with its scene metadata file), a folder by
/// its files' relative paths and bytes (hidden entries and the run folder left out), a missing
/// path by its name.
/// So a project moved or copied elsewhere hashes the same, and an edited library file does
/// not. File digests are cached per process while a file's stat is unchanged. Recorded with
/// every episode and in config.yaml's first line; a run folder may be resumed by any config
/// with the same data hash (e.g. with more workers or another log level). @throws Error for
/// an unreadable file.
MLSPACES_API std::string DataConfigHashHex(const ExperimentConfig& config);

/// The fields DataConfigHashHex hashes: `config` with output_dir, log_level, num_workers,
/// profile and libraries.assets_dir reset to their defaults; with `paths_by_content` every
/// other path replaced by what it holds (as DataConfigHashHex) and the robot's description
/// hash (robot.yaml and its MJCF) added to robot_config.name, else paths replaced by "<path>"
/// (what differs then is a value, never a location). @throws Error for an unreadable file.
MLSPACES_API ExperimentConfig DataFields(const ExperimentConfig& config, bool paths_by_content);

}  // namespace mlspaces::datagen
