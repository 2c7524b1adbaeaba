// Cross-field checks of datagen configs (Validate, config.h).
#include <algorithm>
#include <cmath>
#include <set>

#include "mlspaces/core/error.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/tasks/task_family.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;

namespace {

class Checker {
 public:
  explicit Checker(const fs::path& origin) : origin_(origin.string()) {}

  void Check(bool ok, const std::string& key, const std::string& message) const {
    if (!ok) throw Error(message, origin_, key);  // what(): "<origin>: <key>: <message>"
  }
  void Positive(int64_t v, const std::string& key) const {
    Check(v >= 1, key, "must be >= 1, got " + std::to_string(v));
  }
  void NonNegative(double v, const std::string& key) const {
    Check(std::isfinite(v) && v >= 0, key,
          "must be a finite number >= 0, got " + FormatYamlDouble(v));
  }
  void PositiveReal(double v, const std::string& key) const {
    Check(std::isfinite(v) && v > 0, key,
          "must be a finite number > 0, got " + FormatYamlDouble(v));
  }
  /// a / b is a whole number.
  void Divides(double a, double b, const std::string& key, const std::string& what) const {
    const double r = a / b;
    Check(std::fabs(r - std::round(r)) < 1e-9 * std::max(1.0, std::fabs(r)), key,
          what + " must be a whole number, got " + FormatYamlDouble(r));
  }
  void Pose(const std::optional<std::array<double, 7>>& pose, const std::string& key) const {
    if (!pose) return;
    double n = 0;
    for (size_t i = 0; i < 7; ++i) {
      Check(std::isfinite((*pose)[i]), key, "values must be finite");
      if (i >= 3) n += (*pose)[i] * (*pose)[i];
    }
    Check(std::fabs(std::sqrt(n) - 1.0) < 1e-3, key,
          "the quaternion (values 4-7, wxyz) must have unit length");
  }

 private:
  std::string origin_;
};

}  // namespace

void Validate(const ExperimentConfig& c, const fs::path& origin) {
  Checker k(origin);
  k.Check(c.num_envs == 1, "num_envs",
          "only 1 environment per worker is supported, got " + std::to_string(c.num_envs));
  k.Positive(c.num_workers, "num_workers");
  k.PositiveReal(c.policy_dt_ms, "policy_dt_ms");
  k.PositiveReal(c.ctrl_dt_ms, "ctrl_dt_ms");
  k.PositiveReal(c.sim_dt_ms, "sim_dt_ms");
  k.Divides(c.policy_dt_ms, c.ctrl_dt_ms, "policy_dt_ms", "policy_dt_ms / ctrl_dt_ms");
  k.Divides(c.ctrl_dt_ms, c.sim_dt_ms, "ctrl_dt_ms", "ctrl_dt_ms / sim_dt_ms");
  k.Positive(c.task_horizon, "task_horizon");
  k.Check(!c.data_split.empty(), "data_split", "must not be empty");
  k.Check(!c.output_dir || !c.output_dir->empty(), "output_dir", "must not be empty");

  // name and path of one asset or grasp library entry; returns its key for further checks.
  auto check_library = [&k](const auto& spec, const char* list, size_t i) {
    std::string key = std::string("libraries.") + list + "[" + std::to_string(i) + "]";
    k.Check(!spec.name.empty() && spec.name.find('/') == std::string::npos, key + ".name",
            "must be non-empty and without slashes");
    k.Check(!spec.dir.empty(), key + ".path", "must not be empty");
    return key;
  };
  for (size_t i = 0; i < c.libraries.asset_libraries.size(); ++i) {
    check_library(c.libraries.asset_libraries[i], "asset_libraries", i);
  }
  for (size_t i = 0; i < c.libraries.grasp_libraries.size(); ++i) {
    const GraspLibrarySpec& s = c.libraries.grasp_libraries[i];
    const std::string key = check_library(s, "grasp_libraries", i);
    k.Check(!s.asset_library.empty(), key + ".asset_library", "must not be empty");
  }

  const TaskConfig& t = c.task_config;
  k.Check(!t.pickup_obj_name || !t.pickup_obj_name->empty(), "task_config.pickup_obj_name",
          "must not be empty (use null to let the sampler choose)");
  k.Pose(t.robot_base_pose, "task_config.robot_base_pose");
  k.Pose(t.pickup_obj_start_pose, "task_config.pickup_obj_start_pose");
  k.Pose(t.pickup_obj_goal_pose, "task_config.pickup_obj_goal_pose");
  k.PositiveReal(t.succ_pos_threshold, "task_config.succ_pos_threshold");
  // open / close (docs/tasks.md).
  k.Check(!t.joint_name || !t.joint_name->empty(), "task_config.joint_name",
          "must not be empty (use null to let the sampler choose)");
  if (t.task_success_threshold) {
    const double v = *t.task_success_threshold;
    k.Check(std::isfinite(v) && v > 0 && v <= 1, "task_config.task_success_threshold",
            "must be a fraction of the joint range in (0, 1], got " + std::to_string(v));
  }

  const TaskSamplerConfig& s = c.task_sampler_config;
  const std::string sp = "task_sampler_config.";
  k.Check(!s.task_sampler_class.empty(), sp + "task_sampler_class", "must not be empty");
  k.Check(!s.scene_xml_paths.empty(), sp + "scene_xml_paths",
          "scene_dataset user needs at least one scene");
  if (s.house_inds) {
    k.Check(!s.house_inds->empty(), sp + "house_inds", "must not be empty (null = all scenes)");
    for (int64_t i : *s.house_inds) {
      k.Check(i >= 0 && static_cast<size_t>(i) < s.scene_xml_paths.size(), sp + "house_inds",
              "index " + std::to_string(i) + " is not in [0, " +
                  std::to_string(s.scene_xml_paths.size()) + ")");
    }
  }
  k.Positive(s.samples_per_house, sp + "samples_per_house");
  k.Check(s.house_variant == "base", sp + "house_variant",
          "user scenes have no variants; must be base, got " + s.house_variant);
  k.Positive(s.episodes_per_batch, sp + "episodes_per_batch");
  k.Positive(s.task_batch_size, sp + "task_batch_size");
  if (s.max_tasks) k.Positive(*s.max_tasks, sp + "max_tasks");
  k.Check(s.sim_settle_timesteps >= 0, sp + "sim_settle_timesteps", "must be >= 0");
  k.Positive(s.max_allowed_sequential_task_sampler_failures,
             sp + "max_allowed_sequential_task_sampler_failures");
  k.Positive(s.max_allowed_sequential_rollout_failures,
             sp + "max_allowed_sequential_rollout_failures");
  k.Positive(s.max_allowed_sequential_irrecoverable_failures,
             sp + "max_allowed_sequential_irrecoverable_failures");
  k.Positive(s.max_total_attempts_multiplier, sp + "max_total_attempts_multiplier");
  k.Positive(s.max_asset_failures, sp + "max_asset_failures");
  const std::pair<std::string, const PlanarNoise*> noises[] = {
      {"robot_base_noise", &s.robot_base_noise}, {"object_noise", &s.object_noise}};
  for (const auto& [name, noise] : noises) {
    k.NonNegative(noise->x, sp + name + ".x");
    k.NonNegative(noise->y, sp + name + ".y");
    k.NonNegative(noise->yaw_deg, sp + name + ".yaw_deg");
    k.Check(noise->yaw_deg <= 180, sp + name + ".yaw_deg", "must be <= 180");
  }
  k.Check(std::isfinite(s.goal_offset_z), sp + "goal_offset_z", "must be finite");
  if (s.target_initial_state_open_percentage) {
    const double v = *s.target_initial_state_open_percentage;
    k.Check(std::isfinite(v) && v >= 0 && v <= 1, sp + "target_initial_state_open_percentage",
            "must be a fraction of the joint range in [0, 1], got " + std::to_string(v));
  }
  {
    // The task type's family says which samplers may draw it (tasks/task_family.h); another
    // family's own sampler is refused.
    const TaskFamily& family = TaskFamilyOf(c.task_type);
    const std::string why = family.sampler_refusal(c.task_type, s.task_sampler_class);
    k.Check(why.empty(), sp + "task_sampler_class", why);
    for (const TaskFamily* other : TaskFamilies()) {
      k.Check(other == &family || !other->owns_sampler(s.task_sampler_class),
              sp + "task_sampler_class",
              s.task_sampler_class + " samples " + std::string(other->name) +
                  " tasks; task_type is " + std::string(EnumName(c.task_type)));
    }
  }
  {
    // pick_and_place* (docs/tasks.md): sane bands and limits.
    k.Positive(s.num_place_receptacles, sp + "num_place_receptacles");
    k.NonNegative(s.episodes_per_receptacle, sp + "episodes_per_receptacle");
    k.Positive(s.max_place_receptacle_sampling_attempts,
               sp + "max_place_receptacle_sampling_attempts");
    k.NonNegative(s.min_object_to_receptacle_dist, sp + "min_object_to_receptacle_dist");
    k.Check(std::isfinite(s.max_object_to_receptacle_dist) &&
                s.max_object_to_receptacle_dist >= s.min_object_to_receptacle_dist,
            sp + "max_object_to_receptacle_dist",
            "must be >= min_object_to_receptacle_dist (" +
                std::to_string(s.min_object_to_receptacle_dist) + "), got " +
                std::to_string(s.max_object_to_receptacle_dist));
    k.PositiveReal(s.max_robot_to_place_receptacle_dist, sp + "max_robot_to_place_receptacle_dist");
    const TaskConfig& t = c.task_config;
    k.Check(
        t.receptacle_supported_weight_frac >= 0 && t.receptacle_supported_weight_frac <= 1,
        "task_config.receptacle_supported_weight_frac",
        "must be a fraction in [0, 1], got " + std::to_string(t.receptacle_supported_weight_frac));
    k.NonNegative(t.max_place_receptacle_pos_displacement,
                  "task_config.max_place_receptacle_pos_displacement");
    k.NonNegative(t.max_place_receptacle_rot_displacement,
                  "task_config.max_place_receptacle_rot_displacement");
    k.NonNegative(t.min_surface_to_surface_gap, "task_config.min_surface_to_surface_gap");
    k.Check(t.max_surface_to_surface_gap >= t.min_surface_to_surface_gap,
            "task_config.max_surface_to_surface_gap", "must be >= min_surface_to_surface_gap");
    k.Check(!t.place_receptacle_name || !t.place_receptacle_name->empty(),
            "task_config.place_receptacle_name", "must not be empty");
  }

  const RobotConfig& r = c.robot_config;
  k.Check(!r.name.empty(), "robot_config.name", "must not be empty");
  if (r.base_size) {
    for (double v : *r.base_size) k.PositiveReal(v, "robot_config.base_size");
  }
  for (double v : r.init_qpos_noise_range.arm) {
    k.NonNegative(v, "robot_config.init_qpos_noise_range.arm");
  }
  const ActionNoiseConfig& n = r.action_noise_config;
  const std::string np = "robot_config.action_noise_config.";
  k.NonNegative(n.action_scale_factor, np + "action_scale_factor");
  k.NonNegative(n.rotation_noise_scale, np + "rotation_noise_scale");
  k.NonNegative(n.max_tcp_position_noise, np + "max_tcp_position_noise");
  k.NonNegative(n.max_tcp_rotation_noise, np + "max_tcp_rotation_noise");

  const CameraSystemConfig& cam = c.camera_config;
  k.Check(cam.img_resolution[0] >= 16 && cam.img_resolution[1] >= 16 &&
              cam.img_resolution[0] <= 8192 && cam.img_resolution[1] <= 8192,
          "camera_config.img_resolution", "width and height must be in 16..8192");
  k.Check(cam.depth_max_m > 0, "camera_config.depth_max_m", "must be > 0");
  k.Check(cam.shadow_size == 0 || (cam.shadow_size >= 64 && cam.shadow_size <= 16384),
          "camera_config.shadow_size", "must be 0 (the scene's) or in 64..16384");
  k.Check(cam.multisamples >= -1 && cam.multisamples <= 16, "camera_config.multisamples",
          "must be -1 (the scene's) or in 0..16");
  k.Check(cam.video_crf >= 0 && cam.video_crf <= 51, "camera_config.video_crf", "must be in 0..51");
  static const std::set<std::string> kPresets = {"ultrafast", "superfast", "veryfast", "faster",
                                                 "fast",      "medium",    "slow",     "slower",
                                                 "veryslow",  "placebo"};
  k.Check(kPresets.count(cam.video_preset) != 0, "camera_config.video_preset",
          "must be an x264 preset (ultrafast ... placebo)");
  std::set<std::string> camera_names;
  for (size_t i = 0; i < cam.cameras.size(); ++i) {
    const CameraConfig& cc = cam.cameras[i];
    const std::string key = "camera_config.cameras[" + std::to_string(i) + "]";
    k.Check(!cc.name.empty(), key + ".name", "must not be empty");
    k.Check(camera_names.insert(cc.name).second, key + ".name", "duplicate camera name " + cc.name);
    k.Check(cc.fov > 0 && cc.fov < 180, key + ".fov", "must be in (0, 180) degrees");
    if (cc.type == CameraType::kMjcf) {
      k.Check(!cc.mjcf_name.empty(), key + ".mjcf_name", "an mjcf camera needs mjcf_name");
      k.Check(cc.reference_body_names.empty(), key + ".reference_body_names",
              "only for robot_mounted cameras");
    } else {
      k.Check(!cc.reference_body_names.empty(), key + ".reference_body_names",
              "a robot_mounted camera needs at least one reference body");
      k.Check(cc.mjcf_name.empty(), key + ".mjcf_name", "only for mjcf cameras");
      double q = 0;
      for (double v : cc.camera_quaternion) q += v * v;
      k.Check(std::fabs(std::sqrt(q) - 1.0) < 1e-3, key + ".camera_quaternion",
              "must have unit length (wxyz)");
    }
    for (const auto& [obj, fraction] : cc.visibility_constraints) {
      k.Check(fraction >= 0 && fraction <= 1, key + ".visibility_constraints." + obj,
              "must be in [0, 1]");
    }
  }

  const PolicyConfig& p = c.policy_config;
  const std::string pp = "policy_config.";
  k.Check(!p.policy_cls.empty(), pp + "policy_cls", "must not be empty");
  k.NonNegative(p.pregrasp_z_offset, pp + "pregrasp_z_offset");
  k.NonNegative(p.postgrasp_z_offset, pp + "postgrasp_z_offset");
  k.PositiveReal(p.speed_slow, pp + "speed_slow");
  k.PositiveReal(p.speed_fast, pp + "speed_fast");
  k.NonNegative(p.move_settle_time, pp + "move_settle_time");
  k.NonNegative(p.gripper_close_duration, pp + "gripper_close_duration");
  k.NonNegative(p.gripper_open_duration, pp + "gripper_open_duration");
  k.Check(p.max_retries >= 0, pp + "max_retries", "must be >= 0");
  k.NonNegative(p.gripper_empty_threshold, pp + "gripper_empty_threshold");
  k.PositiveReal(p.phase_timeout, pp + "phase_timeout");
  k.Positive(p.max_sequential_ik_failures, pp + "max_sequential_ik_failures");
  k.PositiveReal(p.tcp_pos_err_threshold, pp + "tcp_pos_err_threshold");
  k.PositiveReal(p.tcp_rot_err_threshold, pp + "tcp_rot_err_threshold");
  k.Positive(p.grasp_collision_batch_size, pp + "grasp_collision_batch_size");
  k.Positive(p.grasp_collision_max_grasps, pp + "grasp_collision_max_grasps");
  k.PositiveReal(p.grasp_width, pp + "grasp_width");
  k.PositiveReal(p.grasp_length, pp + "grasp_length");
  k.PositiveReal(p.grasp_height, pp + "grasp_height");
  k.NonNegative(p.grasp_cost_weights.pos, pp + "grasp_cost_weights.pos");
  k.NonNegative(p.grasp_cost_weights.rot, pp + "grasp_cost_weights.rot");
  k.NonNegative(p.grasp_cost_weights.vertical, pp + "grasp_cost_weights.vertical");
  k.NonNegative(p.grasp_cost_weights.com_dist, pp + "grasp_cost_weights.com_dist");
  k.NonNegative(p.grasp_horizontal_cost_weight, pp + "grasp_horizontal_cost_weight");
  k.Positive(p.grasp_feasibility_batch_size, pp + "grasp_feasibility_batch_size");
  k.Positive(p.grasp_feasibility_max_grasps, pp + "grasp_feasibility_max_grasps");
}

}  // namespace mlspaces::datagen
