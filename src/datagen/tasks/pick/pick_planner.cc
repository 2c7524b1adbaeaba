#include "mlspaces/datagen/tasks/pick/pick_planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "mlspaces/core/se3.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::datagen {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
// Joint-space travel: no joint moves faster than this (rad/s).
constexpr double kMaxJointSpeed = 1.0;

Mat4 RaisedBy(const Mat4& pose, double dz) {
  Mat4 out = pose;
  out(2, 3) += dz;
  return out;
}

Mat4 BodyPose(const mjData* d, int body) { return ToMat4(sim::BodyPose(d, body)); }

}  // namespace

Json PolicyPhaseMap() {
  return Json{{"unknown", 0},       {"gripper-open", 1}, {"pregrasp", 2}, {"grasp", 3},
              {"gripper-close", 4}, {"lift", 5},         {"preplace", 6}, {"place", 7},
              {"retreat", 8},       {"go_home", 9}};
}

const char* PlanFailureName(PlanFailure failure) {
  switch (failure) {
    case PlanFailure::kNone:
      return "none";
    case PlanFailure::kNoGrasp:
      return "no_grasp";
    case PlanFailure::kIkFail:
      return "ik_fail";
    case PlanFailure::kCollision:
      return "collision";
    case PlanFailure::kEmptyGrasp:
      return "empty_grasp";
  }
  return "unknown";
}

PickPlanner::PickPlanner(const Env& env, const robots::RobotView& robot, const PolicyConfig& config,
                         double policy_dt)
    : env_(&env), robot_(&robot), config_(config), dt_policy_(policy_dt) {
  // The tracking IK: one attempt from the previous command (no restarts, which could jump to
  // another branch), few iterations (consecutive targets are close).
  robots::IkOptions ik;
  ik.restarts = 0;
  ik.max_iterations = 200;
  ik_ = std::make_unique<robots::IkSolver>(env.model(), robot.spec().prefix + robot.spec().tcp_site,
                                           robot.arm_joint_names(), std::span<const double>{}, ik);
  if (config_.filter_colliding_grasps) {
    GraspProbeOptions probe;
    probe.gripper_body = robot.spec().prefix + robot.spec().gripper_body;
    probe.tcp_site = robot.spec().prefix + robot.spec().tcp_site;
    probe.robot_prefix = robot.spec().prefix;
    // The probe tests the open hand against the scene and objects. The original's proxies
    // also hit the robot as it stands at planning time, so a retry with the arm down near
    // the object rejected good grasps for touching the arm's current (soon moved) links.
    probe.collide_with_robot = false;
    probe_ = std::make_unique<GraspCollisionChecker>(env.scene().composer(), env.model(), probe);
  }
}

PickPlanner::~PickPlanner() = default;

PickPlanner::Segment PickPlanner::Line(const Mat4& start, const Mat4& end,
                                       const SegmentTiming& timing, PolicyPhase phase) {
  Segment s;
  s.start = start;
  s.end = end;
  s.duration = SegmentDuration(start, end, timing);
  s.phase = phase;
  return s;
}

PickPlanner::Segment PickPlanner::JointTravel(const Mat4& start, const Mat4& end,
                                              std::vector<double> q_start,
                                              std::vector<double> q_end,
                                              const SegmentTiming& timing, PolicyPhase phase) {
  double joint_span = 0;
  for (size_t i = 0; i < q_start.size(); ++i) {
    joint_span = std::max(joint_span, std::abs(q_end[i] - q_start[i]));
  }
  Segment s = Line(start, end, timing, phase);
  s.duration = std::max(s.duration, joint_span / kMaxJointSpeed);
  s.q_start = std::move(q_start);
  s.q_end = std::move(q_end);
  return s;
}

PickPlanner::Primitive PickPlanner::Gripper(PolicyPhase phase, double ctrl, double duration) {
  Primitive p;
  p.phase = phase;
  p.gripper = ctrl;
  p.duration = duration;
  return p;
}

void PickPlanner::Fail(PlanFailure failure, std::string message) {
  failure_ = failure;
  message_ = std::move(message);
}

bool PickPlanner::SolveIk(const Mat4& target, std::vector<double>& q, bool allow_restarts) {
  ik_->options().restarts = allow_restarts ? 8 : 0;
  ik_->options().max_iterations = allow_restarts ? 1000 : 200;
  const robots::IkResult r = ik_->Solve(target, q);
  ++stats_.ik_calls;
  if (!r.success) {
    ++stats_.ik_failures;
    return false;
  }
  q = r.q;
  return true;
}

PlanFailure PickPlanner::Reset(const mjData* d, int object_body, std::vector<Mat4> grasps) {
  object_body_ = object_body;
  grasps_local_ = std::move(grasps);
  retries_ = 0;
  gave_up_ = false;
  pending_retry_ = false;
  failure_ = PlanFailure::kNone;
  message_.clear();
  phase_ = PolicyPhase::kUnknown;
  grasp_ = Mat4{};
  grasp_index_.reset();
  stats_ = PlannerStats{};
  command_ = robot_->ArmQpos(d);
  gripper_command_ = robot_->GripperCtrl(d);
  const PlanFailure f = Plan(d);
  if (f != PlanFailure::kNone) gave_up_ = true;
  return f;
}

PlanFailure PickPlanner::Plan(const mjData* d) {
  const auto t0 = std::chrono::steady_clock::now();
  primitives_.clear();
  current_ = 0;
  started_at_.reset();
  ik_fail_streak_ = 0;
  ik_->SyncState(d);
  if (probe_) probe_->SyncState(d);

  const Mat4 object = BodyPose(d, object_body_);
  const Mat4 tcp = robot_->TcpPose(d);
  const std::vector<Mat4> candidates = GraspsInWorld(object, grasps_local_, true);
  stats_.num_candidates = candidates.size();
  const std::vector<double> q_now = robot_->ArmQpos(d);

  GraspSelectionOptions select;
  select.weights.tcp_distance = config_.grasp_cost_weights.pos;
  select.weights.tcp_angle_deg = config_.grasp_cost_weights.rot;
  select.weights.approach_z = config_.grasp_cost_weights.vertical;
  select.weights.object_distance = config_.grasp_cost_weights.com_dist;
  select.max_ranked = static_cast<size_t>(config_.grasp_collision_max_grasps);
  select.max_ik_checked = config_.filter_feasible_grasps
                              ? static_cast<size_t>(config_.grasp_feasibility_max_grasps)
                              : 1;
  std::vector<double> q_grasp;
  const GraspSelection chosen = SelectGrasp(
      candidates, tcp, object,
      probe_ ? std::function<bool(const Mat4&)>([&](const Mat4& g) { return !probe_->Collides(g); })
             : nullptr,
      [&](const Mat4& g) {
        if (!config_.filter_feasible_grasps) return true;
        std::vector<double> q = q_now;
        if (!SolveIk(g, q, true)) return false;
        q_grasp = std::move(q);
        return true;
      },
      select);
  stats_.num_collision_free = chosen.num_collision_free;
  stats_.num_ik_checked = chosen.num_ik_checked;
  auto finish = [&](PlanFailure f, std::string message) {
    stats_.plan_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (f != PlanFailure::kNone) Fail(f, std::move(message));
    return f;
  };
  if (candidates.empty()) return finish(PlanFailure::kNoGrasp, "the object has no grasps");
  if (!chosen.index) {
    if (chosen.num_collision_free == 0) {
      std::string what;
      if (probe_ && !chosen.ranked.empty()) {
        const std::vector<ProbeContact> hits = probe_->Contacts(candidates[chosen.ranked[0]]);
        if (!hits.empty()) {
          const char* name = mj_id2name(env_->model(), mjOBJ_GEOM, hits[0].sim_geom);
          what = " (the cheapest touches geom " +
                 (name ? std::string(name) : std::to_string(hits[0].sim_geom)) + ")";
        }
      }
      return finish(PlanFailure::kNoGrasp, "every one of " + std::to_string(chosen.ranked.size()) +
                                               " ranked grasps collides with the scene" + what);
    }
    return finish(PlanFailure::kNoGrasp, "no feasible grasp: IK failed for all " +
                                             std::to_string(chosen.num_ik_checked) +
                                             " collision-free candidates");
  }
  grasp_index_ = *chosen.index;
  grasp_ = candidates[*chosen.index];
  const Mat4 pregrasp = RaisedBy(grasp_, config_.pregrasp_z_offset);
  const Mat4 lift = RaisedBy(grasp_, config_.postgrasp_z_offset);
  // The three poses must be reachable (the original's single-pose IK checks).
  std::vector<double> q = q_now;
  if (!SolveIk(pregrasp, q, true))
    return finish(PlanFailure::kIkFail, "pregrasp has no IK solution");
  q = q_grasp.empty() ? q_now : q_grasp;
  if (!SolveIk(grasp_, q, true)) return finish(PlanFailure::kIkFail, "grasp has no IK solution");
  if (!SolveIk(lift, q, true)) return finish(PlanFailure::kIkFail, "lift has no IK solution");

  SegmentTiming fast{config_.speed_fast, 1.0};
  SegmentTiming slow{config_.speed_slow, 1.0};
  const Primitive open = Gripper(PolicyPhase::kGripperOpen, robot_->spec().gripper_open_ctrl, 0);
  Primitive approach;
  approach.move = true;
  approach.settle = config_.move_settle_time;
  if (tcp(2, 3) < lift(2, 3) - 1e-3) {
    // Below the lift height (a retry after a failed grasp): rise straight up to it, cross
    // over at that height to above the new grasp, then descend. Going straight to the
    // pregrasp (4 cm above the grasp) would sweep the open fingers through the object.
    const Mat4 up = RaisedBy(tcp, lift(2, 3) - tcp(2, 3));
    approach.segments.push_back(Line(tcp, up, slow, PolicyPhase::kRetreat));
    approach.segments.push_back(Line(up, lift, fast, PolicyPhase::kPregrasp));
  } else {
    // From above: travel in joint space to the lift pose above the grasp (IK with restarts,
    // seeded from the measured joints). A Cartesian line can need a wrist turn beyond the
    // joint limits (a yawed object) that the per-step IK cannot follow; the joint path
    // reaches any pose the planner found feasible.
    std::vector<double> q_above = q_grasp.empty() ? q_now : q_grasp;
    if (!SolveIk(lift, q_above, true)) {
      return finish(PlanFailure::kIkFail, "lift has no IK solution");
    }
    approach.segments.push_back(
        JointTravel(tcp, lift, q_now, std::move(q_above), fast, PolicyPhase::kPregrasp));
  }
  approach.segments.push_back(Line(lift, pregrasp, fast, PolicyPhase::kPregrasp));
  approach.segments.push_back(Line(pregrasp, grasp_, slow, PolicyPhase::kGrasp));
  const Primitive close = Gripper(PolicyPhase::kGripperClose, robot_->spec().gripper_closed_ctrl,
                                  config_.gripper_close_duration);
  Primitive raise;
  raise.move = true;
  raise.holding = true;
  raise.settle = config_.move_settle_time;
  raise.segments.push_back(Line(grasp_, lift, slow, PolicyPhase::kLift));
  primitives_ = {open, approach, close, raise};
  command_ = q_now;
  return finish(PlanFailure::kNone, "");
}

PlannerAction PickPlanner::Act(const mjData* d) {
  PlannerAction action;
  auto hold = [&](bool done) {
    action.arm = command_;
    action.gripper = gripper_command_;
    action.done = done;
    return action;
  };
  if (gave_up_) return hold(true);
  if (pending_retry_) {
    // The step after a failure: replan from the state it left.
    pending_retry_ = false;
    if (Plan(d) != PlanFailure::kNone) {
      gave_up_ = true;
      return hold(true);
    }
  }
  const double t = d->time;
  auto fail = [&](PlanFailure f, std::string message) {
    Fail(f, std::move(message));
    if (retries_ >= config_.max_retries) {
      gave_up_ = true;
      return hold(true);
    }
    ++retries_;
    pending_retry_ = true;
    // The original returns a no-op for the failing step; we also re-open the gripper so the
    // new plan starts from an open hand.
    gripper_command_ = robot_->spec().gripper_open_ctrl;
    command_ = robot_->ArmQpos(d);
    return hold(false);
  };

  while (current_ < primitives_.size()) {
    const Primitive& p = primitives_[current_];
    if (!started_at_) {
      started_at_ = t;
      if (!p.move) gripper_command_ = p.gripper;
    }
    const double elapsed = t - *started_at_;
    if (!p.move) {
      phase_ = p.phase;
      if (elapsed + 1e-9 >= p.duration) {
        ++current_;
        started_at_.reset();
        continue;
      }
      return hold(false);
    }
    double total = 0;
    for (const Segment& s : p.segments) total += s.duration;
    if (elapsed + 1e-9 >= total + p.settle) {
      ++current_;
      started_at_.reset();
      continue;
    }
    // The segment at time `at`, its target pose and, for joint-space travel, its joints.
    ik_->SyncState(d);
    struct Target {
      Mat4 pose;
      std::vector<double> q;  // empty: Cartesian
      PolicyPhase phase = PolicyPhase::kUnknown;
    };
    auto target_at = [&](double at) {
      double start = 0;
      for (size_t i = 0; i < p.segments.size(); ++i) {
        const Segment& s = p.segments[i];
        if (at < start + s.duration || i + 1 == p.segments.size()) {
          const double u = std::clamp(s.duration > 0 ? (at - start) / s.duration : 1.0, 0.0, 1.0);
          Target t;
          t.phase = s.phase;
          if (s.q_end.empty()) {
            t.pose = InterpolatePose(s.start, s.end, u);
          } else {
            t.q.resize(s.q_end.size());
            for (size_t k = 0; k < t.q.size(); ++k) {
              t.q[k] = s.q_start[k] + u * (s.q_end[k] - s.q_start[k]);
            }
            t.pose = ik_->Forward(t.q);
          }
          return t;
        }
        start += s.duration;
      }
      Target last;
      last.pose = p.segments.back().end;
      last.phase = p.segments.back().phase;
      return last;
    };
    const Target now = target_at(elapsed);
    const Mat4& now_target = now.pose;
    phase_ = now.phase;
    const Mat4 tcp = robot_->TcpPose(d);
    const double pos_err = TranslationDistance(tcp, now_target);
    const double rot_err = RotationAngle(tcp, now_target);
    if (pos_err > config_.tcp_pos_err_threshold ||
        rot_err > config_.tcp_rot_err_threshold * kDegToRad) {
      return fail(PlanFailure::kCollision, "the TCP is " + std::to_string(pos_err) + " m / " +
                                               std::to_string(rot_err / kDegToRad) +
                                               " deg from its target");
    }
    // The original's check: the gap below the robot's closed gap + the threshold (spec 12).
    if (p.holding && robot_->InterFingerDistance(d) <
                         robot_->spec().finger_range[0] + config_.gripper_empty_threshold) {
      return fail(PlanFailure::kEmptyGrasp, "the gripper closed on nothing");
    }
    Target ahead = target_at(elapsed + dt_policy_);
    if (!ahead.q.empty()) {
      command_ = std::move(ahead.q);
      ik_fail_streak_ = 0;
      return hold(false);
    }
    std::vector<double> q = command_;
    if (SolveIk(ahead.pose, q, false)) {
      command_ = std::move(q);
      ik_fail_streak_ = 0;
    } else if (++ik_fail_streak_ >= config_.max_sequential_ik_failures) {
      return fail(PlanFailure::kIkFail,
                  "IK failed " + std::to_string(ik_fail_streak_) + " steps in a row");
    }
    return hold(false);
  }
  return hold(true);
}

}  // namespace mlspaces::datagen
