// The open / close planner (tasks/open_close/planner.h).
#include "mlspaces/datagen/tasks/open_close/planner.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/library/grasp_set.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {
namespace {

constexpr double kHingeStep = 5.0 * std::numbers::pi / 180.0;  // rad between waypoints
constexpr double kSlideStep = 0.01;                            // m between waypoints
constexpr double kApproachBack = 0.12;   // joint-space travel ends this far behind the grasp
constexpr double kRetryBack = 0.08;      // a retry first backs off this far
constexpr double kRetreat = 0.10;        // after release
constexpr double kMinApproachCos = 0.5;  // approach within 60 deg of base -> grasp
// The joint body must reach this far into the space between the open finger pads, along the
// approach and across the pads' width (see Encloses).
constexpr double kMinEnclosed = 0.008;

// An oriented box in world coordinates: centre, unit axes, half sizes.
struct Box {
  Vec3 centre;
  std::array<Vec3, 3> axes;
  Vec3 half;
};

// The separating-axis test of two oriented boxes (touching counts as overlapping).
bool Overlap(const Box& p, const Box& q) {
  const Vec3 t = Sub(q.centre, p.centre);
  auto separated = [&](const Vec3& axis) {
    if (Dot(axis, axis) < 1e-12) return false;  // parallel edges: covered by the face axes
    double rp = 0, rq = 0;
    for (int i = 0; i < 3; ++i) {
      rp += p.half[i] * std::abs(Dot(p.axes[i], axis));
      rq += q.half[i] * std::abs(Dot(q.axes[i], axis));
    }
    return std::abs(Dot(t, axis)) > rp + rq;
  };
  for (int i = 0; i < 3; ++i) {
    if (separated(p.axes[i]) || separated(q.axes[i])) return false;
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (separated(Cross(p.axes[i], q.axes[j]))) return false;
    }
  }
  return true;
}

// A geom's bounding box (MuJoCo's geom_aabb, in the geom frame) in world coordinates.
Box GeomBox(const mjModel* m, const mjData* d, int g) {
  Box b;
  const Mat4 t = sim::GeomBoxFrame(m, d, g, &b.half);
  for (int i = 0; i < 3; ++i) b.axes[i] = {t(0, i), t(1, i), t(2, i)};
  b.centre = {t(0, 3), t(1, 3), t(2, 3)};
  return b;
}

// `pose` moved by `dist` along its own -z (back along the approach axis).
Mat4 Back(const Mat4& pose, double dist) {
  Mat4 out = pose;
  for (int i = 0; i < 3; ++i) out(i, 3) -= dist * pose(i, 2);
  return out;
}

}  // namespace

double OpenedFraction(const TaskJoint& joint, double q) {
  const double span = std::abs(joint.open - joint.closed);
  if (span <= 0) return 0;
  return std::clamp(std::abs(q - joint.closed) / span, 0.0, 1.0);
}

void OpenClosePlanner::ComputePadRegion() {
  // The space between the two open finger pads, in the TCP frame: the robot at the model's
  // reference pose (the gripper open, as the grasp probe assumes) on a scratch mjData.
  const mjModel* m = env_->model();
  const std::string& prefix = robot_->spec().prefix;
  std::array<int, 2> pads{};
  for (int k = 0; k < 2; ++k) {
    pads[k] = mj_name2id(m, mjOBJ_GEOM, (prefix + robot_->spec().finger_pads[k]).c_str());
    if (pads[k] < 0) throw Error("no finger pad geom " + prefix + robot_->spec().finger_pads[k]);
  }
  const sim::DataPtr d = sim::MakeData(m);
  mj_kinematics(m, d.get());
  const int site = robot_->tcp_site();
  const mjtNum* sr = d->site_xmat + 9 * site;
  const Vec3 sp{d->site_xpos[3 * site], d->site_xpos[3 * site + 1], d->site_xpos[3 * site + 2]};
  std::array<Vec3, 2> lo{}, hi{};  // each pad's axis-aligned extent in the TCP frame
  for (int k = 0; k < 2; ++k) {
    const Box b = GeomBox(m, d.get(), pads[k]);
    for (int a = 0; a < 3; ++a) {
      const Vec3 axis{sr[a], sr[3 + a], sr[6 + a]};  // TCP axis a in world
      const double c = Dot(Sub(b.centre, sp), axis);
      double r = 0;
      for (int i = 0; i < 3; ++i) r += b.half[i] * std::abs(Dot(b.axes[i], axis));
      lo[k][a] = c - r;
      hi[k][a] = c + r;
    }
  }
  const int left = (lo[0][1] + hi[0][1]) > (lo[1][1] + hi[1][1]) ? 0 : 1, right = 1 - left;
  Vec3 rlo, rhi;
  for (int a : {0, 2}) {
    rlo[a] = std::max(lo[0][a], lo[1][a]) + kMinEnclosed;
    rhi[a] = std::min(hi[0][a], hi[1][a]) - kMinEnclosed;
  }
  rlo[1] = hi[right][1];
  rhi[1] = lo[left][1];
  for (int a = 0; a < 3; ++a) {
    pad_region_centre_[a] = (rlo[a] + rhi[a]) / 2;
    pad_region_half_[a] = std::max(rhi[a] - rlo[a], 0.002) / 2;
  }
  pad_region_ready_ = true;
}

bool OpenClosePlanner::Encloses(const mjData* d, const Mat4& grasp) const {
  Box region;
  for (int i = 0; i < 3; ++i) region.axes[i] = {grasp(0, i), grasp(1, i), grasp(2, i)};
  region.half = pad_region_half_;
  region.centre = {grasp(0, 3), grasp(1, 3), grasp(2, 3)};
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) region.centre[k] += region.axes[i][k] * pad_region_centre_[i];
  }
  const mjModel* m = env_->model();
  for (int g : joint_geoms_) {
    if (Overlap(region, GeomBox(m, d, g))) return true;
  }
  return false;
}

PlanFailure OpenClosePlanner::ResetJoint(const mjData* d, int joint_id, const TaskJoint& joint,
                                         bool open, double min_fraction, std::vector<Mat4> grasps) {
  joint_id_ = joint_id;
  joint_ = joint;
  open_ = open;
  min_fraction_ = min_fraction;
  planned_fraction_ = 0;
  failed_grasps_.clear();
  if (!pad_region_ready_) ComputePadRegion();
  // The collision geoms of the joint body's subtree (the door or drawer with its handle).
  const mjModel* m = env_->model();
  const int joint_body = m->jnt_bodyid[joint_id];
  joint_geoms_ = sim::CollisionGeoms(m, joint_body);
  return Reset(d, env_->model()->jnt_bodyid[joint_id], std::move(grasps));
}

PlanFailure OpenClosePlanner::Plan(const mjData* d) {
  const auto t0 = std::chrono::steady_clock::now();
  const mjModel* m = env_->model();
  primitives_.clear();
  current_ = 0;
  started_at_.reset();
  ik_fail_streak_ = 0;
  ik_->SyncState(d);
  if (probe_) probe_->SyncState(d);
  auto finish = [&](PlanFailure f, std::string message) {
    stats_.plan_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (f != PlanFailure::kNone) Fail(f, std::move(message));
    return f;
  };

  const Mat4 body = ToMat4(sim::BodyPose(d, object_body_));
  const Mat4 tcp = robot_->TcpPose(d);
  const std::vector<Mat4> all = GraspsInWorld(body, grasps_local_, true);
  stats_.num_candidates = all.size();
  if (all.empty()) return finish(PlanFailure::kNoGrasp, "the joint has no grasps");
  // Grasps that approach the handle from the robot's side (approach axis within 60 degrees
  // of the horizontal direction from the robot base to the grasp): a hand coming in from the
  // side or from behind the handle sweeps along the door or front first. All of them when
  // none does.
  // A retry does not take the grasp that just failed again (the original replans from the
  // same ranking and usually takes it again).
  if (retries_ > 0 && grasp_index_) failed_grasps_.push_back(*grasp_index_);
  std::vector<Mat4> candidates;
  std::vector<size_t> source;  // index into `all`
  const Mat4 base = robot_->BasePose(d);
  for (size_t i = 0; i < all.size(); ++i) {
    const Mat4& g = all[i];
    if (std::find(failed_grasps_.begin(), failed_grasps_.end(), i) != failed_grasps_.end()) {
      continue;
    }
    double dx = g(0, 3) - base(0, 3), dy = g(1, 3) - base(1, 3);
    const double norm = std::hypot(dx, dy);
    if (norm < 1e-9) continue;
    dx /= norm;
    dy /= norm;
    if (g(0, 2) * dx + g(1, 2) * dy >= kMinApproachCos) {
      candidates.push_back(g);
      source.push_back(i);
    }
  }
  // The rest, tried when none of those is collision-free and reachable (another gripper
  // than the one the grasps were made for may fit only from the side).
  std::vector<Mat4> rest;
  std::vector<size_t> rest_source;
  for (size_t i = 0; i < all.size(); ++i) {
    if (std::find(failed_grasps_.begin(), failed_grasps_.end(), i) != failed_grasps_.end() ||
        std::find(source.begin(), source.end(), i) != source.end()) {
      continue;
    }
    rest.push_back(all[i]);
    rest_source.push_back(i);
  }
  const std::vector<double> q_now = robot_->ArmQpos(d);

  // The joint's motion: positions from now to the goal, and the rigid motion of the joint
  // body for a change dq (about the world axis through the anchor, or along it).
  const double q_joint = d->qpos[m->jnt_qposadr[joint_id_]];
  const double goal = open_ ? joint_.open : joint_.closed;
  const bool hinge = m->jnt_type[joint_id_] == mjJNT_HINGE;
  const double step = hinge ? kHingeStep : kSlideStep;
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(goal - q_joint) / step)));
  const Vec3 axis{d->xaxis[3 * joint_id_], d->xaxis[3 * joint_id_ + 1],
                  d->xaxis[3 * joint_id_ + 2]};
  const Vec3 anchor{d->xanchor[3 * joint_id_], d->xanchor[3 * joint_id_ + 1],
                    d->xanchor[3 * joint_id_ + 2]};
  auto motion = [&](double dq) {
    if (!hinge) return Translate({axis[0] * dq, axis[1] * dq, axis[2] * dq});
    return Translate(anchor) * AxisAngle(axis, dq) *
           Translate({-anchor[0], -anchor[1], -anchor[2]});
  };
  auto reached = [&](double f) { return open_ ? f >= min_fraction_ : f <= 1.0 - min_fraction_; };

  // A grasp is feasible when the grasp, the pregrasp, the travel's end and enough of the
  // articulation have IK solutions (the original checks only the first two).
  std::vector<double> q_grasp, q_back;
  std::vector<Mat4> waypoints;
  double fraction_end = 0;
  std::string why_not;
  auto feasible = [&](const Mat4& g) {
    if (!config_.filter_feasible_grasps) return true;
    std::vector<double> q = q_now;
    if (!SolveIk(g, q, true)) return false;
    std::vector<double> qb = q;
    if (!SolveIk(Back(g, kApproachBack), qb, true)) return false;
    std::vector<double> qp = q;
    if (!SolveIk(Back(g, config_.pregrasp_z_offset), qp, true)) return false;
    std::vector<Mat4> path{g};
    std::vector<double> qa = q;
    double f = OpenedFraction(joint_, q_joint);
    for (int k = 1; k <= n; ++k) {
      const double dq = (goal - q_joint) * k / n;
      const Mat4 w = motion(dq) * g;
      if (!SolveIk(w, qa, false)) break;
      path.push_back(w);
      f = OpenedFraction(joint_, q_joint + dq);
    }
    if (!reached(f)) {
      why_not = "the articulation is reachable only to an opened fraction of " + std::to_string(f);
      return false;
    }
    q_grasp = std::move(q);
    q_back = std::move(qb);
    waypoints = std::move(path);
    fraction_end = f;
    return true;
  };

  GraspSelectionOptions select;
  select.weights.tcp_distance = config_.grasp_cost_weights.pos;
  select.weights.tcp_angle_deg = config_.grasp_cost_weights.rot;
  select.weights.approach_z = config_.grasp_cost_weights.vertical;
  select.weights.approach_z_sq = config_.grasp_horizontal_cost_weight;
  select.weights.object_distance = config_.grasp_cost_weights.com_dist;
  select.max_ranked = static_cast<size_t>(config_.grasp_collision_max_grasps);
  select.max_ik_checked = config_.filter_feasible_grasps
                              ? static_cast<size_t>(config_.grasp_feasibility_max_grasps)
                              : 1;
  // A grasp must also hold part of the joint body between the open pads, at least
  // kMinEnclosed deep (the grasps were made for one gripper; a gripper with shorter or
  // parallel-sliding fingers closes in front of a handle that the other one's catches).
  size_t num_not_enclosing = 0;
  const std::function<bool(const Mat4&)> collision_free =
      probe_ ? std::function<bool(const Mat4&)>([&](const Mat4& g) {
        if (!Encloses(d, g)) {
          ++num_not_enclosing;
          return false;
        }
        return !probe_->Collides(g);
      })
             : nullptr;
  GraspSelection chosen = SelectGrasp(candidates, tcp, body, collision_free, feasible, select);
  if (!chosen.index && !rest.empty()) {
    const GraspSelection second = SelectGrasp(rest, tcp, body, collision_free, feasible, select);
    if (second.index || candidates.empty()) {
      chosen = second;
      candidates = std::move(rest);
      source = std::move(rest_source);
    }
  }
  stats_.num_collision_free = chosen.num_collision_free;
  stats_.num_ik_checked = chosen.num_ik_checked;
  if (!chosen.index) {
    if (chosen.num_collision_free == 0) {
      return finish(PlanFailure::kNoGrasp,
                    "every one of " + std::to_string(chosen.ranked.size()) +
                        " ranked joint grasps collides with the scene or holds nothing between "
                        "the open pads (" +
                        std::to_string(num_not_enclosing) +
                        " candidates held nothing, over both tiers)");
    }
    return finish(PlanFailure::kNoGrasp,
                  "no feasible joint grasp among " + std::to_string(chosen.num_ik_checked) +
                      " collision-free candidates" + (why_not.empty() ? "" : " (" + why_not + ")"));
  }
  grasp_index_ = source[*chosen.index];
  grasp_ = candidates[*chosen.index];
  if (waypoints.empty()) {  // feasibility checks off: the whole motion, unchecked
    waypoints.push_back(grasp_);
    for (int k = 1; k <= n; ++k) waypoints.push_back(motion((goal - q_joint) * k / n) * grasp_);
    fraction_end = OpenedFraction(joint_, goal);
    q_grasp = q_now;
    q_back = q_now;
    SolveIk(Back(grasp_, kApproachBack), q_back, true);
  }
  planned_fraction_ = fraction_end;

  const SegmentTiming fast{config_.speed_fast, 1.0};
  const SegmentTiming slow{config_.speed_slow, 1.0};
  const Primitive open = Gripper(PolicyPhase::kGripperOpen, robot_->spec().gripper_open_ctrl, 0);
  Primitive approach;
  approach.move = true;
  approach.settle = config_.move_settle_time;
  Mat4 from = tcp;
  std::vector<double> q_from = q_now;
  if (retries_ > 0) {
    // A retry starts with the hand at the handle: back off along the approach axis first.
    const Mat4 backed = Back(tcp, kRetryBack);
    std::vector<double> qb = q_now;
    if (SolveIk(backed, qb, false)) {
      approach.segments.push_back(Line(tcp, backed, slow, PolicyPhase::kRetreat));
      from = backed;
      q_from = qb;
    }
  }
  const Mat4 behind = Back(grasp_, kApproachBack);
  approach.segments.push_back(
      JointTravel(from, behind, q_from, q_back, fast, PolicyPhase::kPregrasp));
  const Mat4 pregrasp = Back(grasp_, config_.pregrasp_z_offset);
  approach.segments.push_back(Line(behind, pregrasp, fast, PolicyPhase::kPregrasp));
  approach.segments.push_back(Line(pregrasp, grasp_, slow, PolicyPhase::kGrasp));
  const Primitive close = Gripper(PolicyPhase::kGripperClose, robot_->spec().gripper_closed_ctrl,
                                  config_.gripper_close_duration);
  Primitive articulate;
  articulate.move = true;
  articulate.holding = true;
  articulate.settle = config_.move_settle_time;
  for (size_t k = 1; k < waypoints.size(); ++k) {
    articulate.segments.push_back(Line(waypoints[k - 1], waypoints[k], slow, PolicyPhase::kLift));
  }
  const Primitive release = Gripper(PolicyPhase::kGripperOpen, robot_->spec().gripper_open_ctrl,
                                    config_.gripper_close_duration);
  Primitive retreat;
  retreat.move = true;
  retreat.settle = 0;
  const Mat4& last = waypoints.back();
  retreat.segments.push_back(Line(last, Back(last, kRetreat), fast, PolicyPhase::kRetreat));
  primitives_ = {open, approach, close};
  if (!articulate.segments.empty()) primitives_.push_back(articulate);
  primitives_.push_back(release);
  primitives_.push_back(retreat);
  command_ = q_now;
  return finish(PlanFailure::kNone, "");
}

}  // namespace mlspaces::datagen
