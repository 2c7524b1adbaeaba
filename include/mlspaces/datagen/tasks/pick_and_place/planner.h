// The pick-and-place planner (spec A.5.4, A.6; docs/tasks.md): the pick planner's grasp and
// execution (PickPlanner::Act) with its own plan after the grasp:
//   lift: the grasp raised to the place height (receptacle AABB top + c + place_z_offset,
//     c = grasp z - object AABB bottom), at least postgrasp_z_offset;
//   preplace: the grasp's orientation above the place point at the place height, the
//     grasp-to-object xy offset kept (the original adds the z offset too, spec A.8 item 7),
//     carried at speed_slow; when preplace or place is out of reach the held object is turned
//     about the vertical through the place point (the first of a few turns both reach);
//   place: preplace lowered to receptacle top + c + 5 mm (into / onto) or to the target
//     surface + c + 1 cm (next to);
//   release (gripper open), retreat end_z_offset back along the approach axis,
//   go_home (joint space to the robot's home), a 2 s no-op (phase unknown). Every pose up to
//   place is IK-checked at plan time; a retry (failure while holding) replans from the grasp.
// Place point: the receptacle's AABB centre (into / onto); next to: a point beside the
// target, on the side nearest the object's start, at the gap ResetPlace is given (the
// runner: the middle of the task's surface-gap band).
#pragma once

#include "mlspaces/core/export.h"

#include <vector>

#include "mlspaces/datagen/tasks/pick/pick_planner.h"

namespace mlspaces::datagen {

class MLSPACES_API PickAndPlacePlanner : public PickPlanner {
 public:
  using PickPlanner::PickPlanner;

  /// Starts an episode: pick `object_body` with `grasps` and put it into / onto (next_to
  /// false) or next to `place_body`. @returns kNone or why no plan exists (message()).
  PlanFailure ResetPlace(const mjData* d, int object_body, int place_body, bool next_to, double gap,
                         std::vector<Mat4> grasps);

 protected:
  PlanFailure Plan(const mjData* d) override;

 private:
  int place_body_ = -1;
  bool next_to_ = false;
  double gap_ = 0.025;
};

}  // namespace mlspaces::datagen
