// Pick-and-place success (spec A.5.5, A.6; docs/tasks.md), judged once per policy step in
// order (the carry-forward memory changes with each call, as the original's get_info).
//
// into / onto (pick_and_place, pick_and_place_color): all of
//   supported: (a) the contact forces of the receptacle on the object sum to a force within
//     30 deg of +z whose vertical part is >= receptacle_supported_weight_frac x the object's
//     weight; else (b) a receptacle contact below the object's AABB centre with its normal
//     within 30 deg of +z, or the object's AABB centre inside the receptacle's xy AABB with
//     its bottom between the receptacle's mid height and top + 1 cm; else (c) carry-forward:
//     the object's pose in the receptacle frame within 5 mm and 10 deg of one stored at a
//     supported step;
//   no contact between the object and the robot;
//   the receptacle moved <= max_place_receptacle_pos_displacement and tilted (its z axis
//   turned) <= max_place_receptacle_rot_displacement.
//   reward = exp(-|object origin - receptacle AABB centre|).
// next to: the xy gap between the two AABBs in [min_surface_to_surface_gap,
//   max_surface_to_surface_gap + 0.01], both resting on the same root body, the target moved
//   <= max_place_receptacle_pos_displacement and rotated <= the rotation limit; reward =
//   exp(-gap).
#pragma once

#include "mlspaces/core/export.h"

#include <string_view>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/json.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/datagen/config.h"

namespace mlspaces::datagen {

/// World AABB of a body's subtree geoms (planes left out): {min, max}; min > max when it
/// has none.
MLSPACES_API std::array<Vec3, 2> SubtreeAabb(const mjModel* m, const mjData* d, int body);

struct MLSPACES_API PlaceVerdict {
  bool success = false;
  double reward = 0;
  bool supported_by_receptacle = false;  ///< (a) or (b), or (c) below
  bool supported_by_carry_forward = false;
  double carry_forward_pos_diff = 0, carry_forward_rot_diff = 0;
  bool robot_contact = false;
  double position_error = 0;           ///< receptacle AABB centre to the object's AABB (0 inside)
  Vec3 receptacle_pos_displacement{};  ///< receptacle frame
  double receptacle_rot_displacement = 0, receptacle_tilt_displacement = 0;  ///< rad
  // next to
  double min_surface_gap = 0;
  bool within_distance_range = false, on_same_surface = false;
  /// The original's task_info keys for this task type.
  Json Info(TaskType type, int64_t step) const;
};

/// Judges one state; `memory` is the carry-forward store (empty at the episode's start).
class MLSPACES_API PlaceJudge {
 public:
  PlaceJudge(const mjModel* m, int object_body, int receptacle_body, const Pose& receptacle_start,
             TaskType type, const TaskConfig& config, std::string robot_prefix);
  PlaceVerdict Evaluate(const mjData* d);

 private:
  const mjModel* m_;
  int object_, receptacle_;
  Mat4 receptacle_start_;
  TaskType type_;
  TaskConfig config_;
  std::string prefix_;
  std::vector<Mat4> memory_;  // object in receptacle frame, at supported steps
};

/// "Pick up the <p> and place it in or on the <q>" / "... next to the <q>" / "... in or on
/// the <colour> <q>" (colour underscores as spaces).
MLSPACES_API std::string PlaceDescription(TaskType type, const std::string& pickup,
                                          const std::string& place, const std::string& color);

}  // namespace mlspaces::datagen
