// The pick-and-place planner (tasks/pick_and_place/planner.h).
#include "mlspaces/datagen/tasks/pick_and_place/planner.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "mlspaces/core/se3.h"
#include "mlspaces/datagen/tasks/pick_and_place/success.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::datagen {
namespace {

constexpr double kNoopSeconds = 2.0;  // the original's final NoopAction

Mat4 WithZ(const Mat4& pose, double z) {
  Mat4 out = pose;
  out(2, 3) = z;
  return out;
}

// `pose` moved by -dist along its approach (TCP z) axis.
Mat4 BackOff(const Mat4& pose, double dist) {
  Mat4 out = pose;
  for (int i = 0; i < 3; ++i) out(i, 3) -= dist * pose(i, 2);
  return out;
}

}  // namespace

PlanFailure PickAndPlacePlanner::ResetPlace(const mjData* d, int object_body, int place_body,
                                            bool next_to, double gap, std::vector<Mat4> grasps) {
  place_body_ = place_body;
  next_to_ = next_to;
  gap_ = gap;
  return Reset(d, object_body, std::move(grasps));
}

PlanFailure PickAndPlacePlanner::Plan(const mjData* d) {
  // The pick plan: open, approach, grasp, close, lift (replaced below).
  const PlanFailure picked = PickPlanner::Plan(d);
  if (picked != PlanFailure::kNone) return picked;
  const mjModel* m = env_->model();
  const std::array<Vec3, 2> ob = SubtreeAabb(m, d, object_body_);
  const std::array<Vec3, 2> rb = SubtreeAabb(m, d, place_body_);
  const double c = std::max(grasp_(2, 3) - ob[0][2], 0.0);
  // The place point (xy) and the height the object's bottom goes to.
  double px = 0.5 * (rb[0][0] + rb[1][0]), py = 0.5 * (rb[0][1] + rb[1][1]);
  double bottom = rb[1][2];
  if (next_to_) {
    // Beside the target, on the side of the object's start, gap_ between the AABBs.
    const double ocx = 0.5 * (ob[0][0] + ob[1][0]), ocy = 0.5 * (ob[0][1] + ob[1][1]);
    double dx = ocx - px, dy = ocy - py;
    const double n = std::max(std::hypot(dx, dy), 1e-9);
    dx /= n;
    dy /= n;
    // Centre distance so the AABBs (seen along the direction) are gap_ apart.
    const double rext =
        0.5 * (std::abs(dx) * (rb[1][0] - rb[0][0]) + std::abs(dy) * (rb[1][1] - rb[0][1]));
    const double oext =
        0.5 * (std::abs(dx) * (ob[1][0] - ob[0][0]) + std::abs(dy) * (ob[1][1] - ob[0][1]));
    px += dx * (rext + oext + gap_);
    py += dy * (rext + oext + gap_);
    bottom = ob[0][2] + 0.01;
  }
  const double travel_z =
      std::max(rb[1][2], ob[1][2] - ob[0][2] + bottom) + c + config_.place_z_offset;
  // Grasp-to-object xy offset kept (the object, not the TCP, goes to the place point).
  const double ox = grasp_(0, 3) - 0.5 * (ob[0][0] + ob[1][0]);
  const double oy = grasp_(1, 3) - 0.5 * (ob[0][1] + ob[1][1]);
  const Mat4 lift = WithZ(grasp_, std::max(travel_z, grasp_(2, 3) + config_.postgrasp_z_offset));
  Mat4 preplace0 = WithZ(grasp_, lift(2, 3));
  preplace0(0, 3) = px + ox;
  preplace0(1, 3) = py + oy;
  // The held object may turn about the vertical through the place point on the way (its yaw
  // at the target is free): the first turn, smallest first, whose preplace
  // and place have IK solutions (the original keeps the grasp's yaw, and fails when that
  // pose is out of reach).
  const std::vector<double> turns{0.0, 0.5, -0.5, 1.0, -1.0, 1.57, -1.57, 2.36, -2.36, 3.14};
  std::vector<double> q = robot_->ArmQpos(d);
  if (!SolveIk(grasp_, q, true) || !SolveIk(lift, q, true)) {
    Fail(PlanFailure::kIkFail, "lift has no IK solution");
    return PlanFailure::kIkFail;
  }
  const std::vector<double> q_lift = q;
  Mat4 preplace, place;
  std::vector<double> q_preplace;
  bool reached = false;
  for (double turn : turns) {
    const Mat4 about = Translate({px, py, 0}) * RotZ(turn) * Translate({-px, -py, 0});
    preplace = about * preplace0;
    place = WithZ(preplace, bottom + c + (next_to_ ? 0.0 : 0.005));
    q = q_lift;
    if (!SolveIk(preplace, q, true)) continue;
    q_preplace = q;
    if (SolveIk(place, q, true)) {
      reached = true;
      break;
    }
  }
  if (!reached) {
    Fail(PlanFailure::kIkFail, "preplace / place have no IK solution at any turn of the object");
    return PlanFailure::kIkFail;
  }
  const Mat4 postplace = BackOff(place, config_.end_z_offset);
  std::vector<double> q_post = q;
  if (!SolveIk(postplace, q_post, true)) {
    Fail(PlanFailure::kIkFail, "postplace has no IK solution");
    return PlanFailure::kIkFail;
  }
  const SegmentTiming fast{config_.speed_fast, 1.0};
  const SegmentTiming slow{config_.speed_slow, 1.0};
  Primitive& carry = primitives_.back();  // the pick's lift, holding
  carry.segments.clear();
  carry.segments.push_back(Line(grasp_, lift, slow, PolicyPhase::kLift));
  // Carried at speed_slow (the original: speed_fast), which lets fewer objects slip out of
  // the fingers, in joint space (as the pick planner's approach): a turn of the object can need
  // a wrist turn that per-step IK along a Cartesian line cannot follow.
  carry.segments.push_back(
      JointTravel(lift, preplace, q_lift, q_preplace, slow, PolicyPhase::kPreplace));
  carry.segments.push_back(Line(preplace, place, slow, PolicyPhase::kPlace));
  primitives_.push_back(Gripper(PolicyPhase::kGripperOpen, robot_->spec().gripper_open_ctrl,
                                config_.gripper_close_duration * 0.5));
  Primitive retreat;
  retreat.move = true;
  retreat.settle = config_.move_settle_time;
  retreat.segments.push_back(Line(place, postplace, fast, PolicyPhase::kRetreat));
  primitives_.push_back(retreat);
  Primitive home;
  home.move = true;
  home.settle = config_.move_settle_time;
  const std::vector<double>& h = env_->home_qpos();
  std::vector<double> q_home(h.begin(), h.begin() + static_cast<std::ptrdiff_t>(q_post.size()));
  home.segments.push_back(
      JointTravel(postplace, ik_->Forward(q_home), q_post, q_home, fast, PolicyPhase::kGoHome));
  primitives_.push_back(home);
  primitives_.push_back(
      Gripper(PolicyPhase::kUnknown, robot_->spec().gripper_open_ctrl, kNoopSeconds));
  return PlanFailure::kNone;
}

}  // namespace mlspaces::datagen
