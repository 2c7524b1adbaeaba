// Grasp simulation, articulated test: approach without disturbing the joint, close on the
// handle with both fingers, sweep the hand along the joint's motion and back
// (include/mlspaces/graspgen/grasp_sim.h, docs/graspgen.md "Simulation").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "grasp_sim_internal.h"
#include "mlspaces/core/error.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::graspgen {
namespace {

constexpr double kSimApproach = 0.05;  // m simulated before the grasp pose (the rest: geometry)
constexpr int kApproachSteps = 50;     // 0.5 m/s
constexpr int kHoldSteps = 10;
constexpr int kWaypoints = 100;  // per direction (the original: 401 x 10 steps)
constexpr int kWaypointSteps = 10;
constexpr int kCheckEvery = 10;  // waypoints; checked below 90 % of the sweep, as the original

std::string Num(const char* format, double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

}  // namespace

SimOutcome GraspScene::TestJoint(const JointTarget& target, const Mat4& tcp, mjData* data) const {
  const Impl& s = *impl_;
  const mjModel* m = s.model.get();
  if (s.mode != Mode::kArticulated)
    throw Error("TestJoint needs an articulated-mode scene", s.source);
  const int joint = mj_name2id(m, mjOBJ_JOINT, target.joint.c_str());
  if (joint < 0) throw Error("joint '" + target.joint + "' is not in the model", s.source);
  const int type = m->jnt_type[joint];
  if (type != mjJNT_HINGE && type != mjJNT_SLIDE) {
    throw Error("joint '" + target.joint + "' is not a hinge or slide joint", s.source);
  }
  if (!(std::abs(target.travel) > 0)) {
    throw Error("joint '" + target.joint + "' has no travel to test", s.source);
  }
  const bool hinge = type == mjJNT_HINGE;
  const int body = m->jnt_bodyid[joint];
  const int qadr = m->jnt_qposadr[joint];
  SimOutcome out;

  mj_resetData(m, data);
  mj_kinematics(m, data);
  const Mat4 body0 = BodyMat4(data, body);
  const Mat4 grasp = body0 * tcp;  // world
  const Vec3 z{grasp(0, 2), grasp(1, 2), grasp(2, 2)};
  // Geometry first: the open hand must not touch the object on the approach line from
  // joint_approach_distance to the last kSimApproach, which is simulated.
  const Mat4 tcp_in_root = InverseRigid(BodyMat4(data, s.object)) * grasp;
  if (s.ApproachBlocked(tcp_in_root, kSimApproach,
                        std::max(kSimApproach, s.params.joint_approach_distance))) {
    out.reason = "approach path blocked";
    return out;
  }
  const auto back = [&](double dist) {
    return Translate({-dist * z[0], -dist * z[1], -dist * z[2]}) * grasp;
  };
  const double q0 = data->qpos[qadr];
  data->ctrl[s.actuator] = s.open_ctrl;
  s.PlaceHand(data, back(kSimApproach));
  for (int k = 1; k <= kApproachSteps + kHoldSteps; ++k) {
    s.SetTcp(data, back(kSimApproach * std::max(0, kApproachSteps - k) / kApproachSteps));
    mj_step(m, data);
    ++out.steps;
  }
  if (std::abs(data->qpos[qadr] - q0) > s.params.max_approach_disturbance) {
    out.reason = "approach moved the joint: " +
                 Num(hinge ? "%.3f rad" : "%.4f m", std::abs(data->qpos[qadr] - q0));
    return out;
  }
  out.steps += s.Close(m, data);
  std::vector<char> handle(m->nbody, 0);
  for (int b = 1; b < m->nbody; ++b) {
    int a = b;
    while (a != 0 && a != body) a = m->body_parentid[a];
    handle[b] = a == body;
  }
  const int sides = s.FingerContacts(data, handle);
  if (sides != 3) {
    out.reason = sides == 0 ? "not held after closing" : "one finger after closing";
    return out;
  }
  out.tcp = InverseRigid(BodyMat4(data, body)) * sim::SiteMat4(data, s.site);

  // The joint's world axis and anchor at qpos0 (the object root is fixed).
  const Rot3 r0 = Rotation(body0);
  Vec3 axis{0, 0, 0}, anchor{0, 0, 0};
  for (int row = 0; row < 3; ++row) {
    anchor[row] = body0(row, 3);
    for (int k = 0; k < 3; ++k) {
      axis[row] += r0[3 * row + k] * target.axis[k];
      anchor[row] += r0[3 * row + k] * target.anchor[k];
    }
  }
  const double norm = std::hypot(axis[0], axis[1], axis[2]);
  for (double& v : axis) v /= norm;
  const auto waypoint = [&](int i) {
    // Eased (1 - cos) so the hand starts and stops at rest: no jerk on the handle.
    const double x = target.travel * (1 - std::cos(std::numbers::pi * i / kWaypoints)) / 2;
    if (!hinge) return Translate({axis[0] * x, axis[1] * x, axis[2] * x}) * grasp;
    return Translate(anchor) * AxisAngle(axis, x) *
           Translate({-anchor[0], -anchor[1], -anchor[2]}) * grasp;
  };
  double best = 0;  // fraction of the travel reached
  const auto sweep = [&](bool forward) -> std::string {
    for (int n = 1; n <= kWaypoints; ++n) {
      const int i = forward ? n : kWaypoints - n;
      s.SetTcp(data, waypoint(i));
      for (int k = 0; k < kWaypointSteps; ++k) mj_step(m, data);
      out.steps += kWaypointSteps;
      if (forward) best = std::max(best, (data->qpos[qadr] - q0) / target.travel);
      if (n % kCheckEvery == 0 && n < 0.9 * kWaypoints && s.FingerContacts(data, handle) != 3) {
        return forward ? "lost the handle while opening" : "lost the handle while closing";
      }
    }
    return {};
  };
  out.reason = sweep(true);
  if (out.reason.empty() && best < s.params.min_travel_fraction) {
    out.reason = "joint moved too little: " + Num("%.0f%% of its travel", 100 * best);
  }
  if (out.reason.empty()) out.reason = sweep(false);
  out.success = out.reason.empty();
  if (!out.success) out.tcp = Mat4{};
  return out;
}

}  // namespace mlspaces::graspgen
