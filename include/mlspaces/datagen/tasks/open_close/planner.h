// The open / close planner (spec A.3.5-3.6; docs/tasks.md): the pick planner's execution
// (PickPlanner::Act: per-step IK, TCP-error and finger-gap checks, retries) with its own plan.
//
// Plan (at the start and on every retry), from the measured state:
//   1. candidates = the joint body's pose x its joint grasps, plus their 180-degree flips about
//      the TCP z, less those that failed earlier in the episode; first those approaching from
//      the robot's side (approach within 60 degrees of base -> grasp), then, when none of them
//      passes, the others; cost = the pick cost with policy_config.grasp_horizontal_cost_weight
//      on G[2,2]^2 (side grasps on handles win); collision probe and IK as the pick planner,
//      and a grasp must hold part of the joint body between the open finger pads (at
//      least 8 mm into the pads' length and width: grasps made for another gripper);
//   2. waypoints of the joint motion from its current position to the goal (open: the open
//      limit; close: the closed limit), every 5 degrees (hinge: the grasp rotated about the
//      joint's world axis through its anchor, i.e. the door's arc) or 1 cm (slide: the grasp
//      translated along the axis); each is IK-checked in turn from the grasp's solution and
//      the motion stops at the last reachable one (it must reach the success threshold);
//   3. primitives: gripper open -> (retry: back off 8 cm along the TCP's approach axis) ->
//      joint-space travel to 12 cm behind the grasp along its approach axis -> pregrasp
//      (pregrasp_z_offset behind, speed_fast) -> grasp (speed_slow) -> settle -> close ->
//      articulate (speed_slow, holding; phase "lift", the original's name) -> settle ->
//      open (gripper_close_duration; phase "gripper-open") -> retreat 10 cm back along the
//      approach axis (phase "retreat").
#pragma once

#include "mlspaces/core/export.h"

#include <vector>

#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/datagen/tasks/pick/pick_planner.h"

namespace mlspaces::datagen {

class MLSPACES_API OpenClosePlanner : public PickPlanner {
 public:
  using PickPlanner::PickPlanner;

  /// Starts an episode: move joint `joint_id` (`joint` as sampled) to its open (`open` true)
  /// or closed limit, holding the joint body with `grasps` (in that body's frame).
  /// `min_fraction`: the articulation must reach this opened fraction (open) or come down to
  /// 1 - it (close) to be planned. @returns kNone or why no plan exists (message()).
  PlanFailure ResetJoint(const mjData* d, int joint_id, const TaskJoint& joint, bool open,
                         double min_fraction, std::vector<Mat4> grasps);

  /// The opened fraction the plan's articulation ends at.
  double planned_fraction() const { return planned_fraction_; }

 protected:
  PlanFailure Plan(const mjData* d) override;

 private:
  int joint_id_ = -1;
  TaskJoint joint_;
  bool open_ = true;
  double min_fraction_ = 0;
  double planned_fraction_ = 0;
  std::vector<size_t> failed_grasps_;  // candidates that failed in this episode
  std::vector<int> joint_geoms_;       // collision geoms of the joint body's subtree

  // The region between the open finger pads (TCP frame), less kMinEnclosed along x and z.
  void ComputePadRegion();
  // True when one of joint_geoms_ (bounding boxes, state in `d`) reaches into the region
  // with the TCP at `grasp`.
  bool Encloses(const mjData* d, const Mat4& grasp) const;
  bool pad_region_ready_ = false;
  Vec3 pad_region_centre_{}, pad_region_half_{};
};

/// The opened fraction of a joint at position q: |q - closed| / |open - closed|, in [0, 1].
MLSPACES_API double OpenedFraction(const TaskJoint& joint, double q);

}  // namespace mlspaces::datagen
