// Grasp simulation, the support test: a rigid grasp that passed the zero-gravity test, tried
// as a pick of the object resting on a support under gravity (docs/graspgen.md "Simulation").
// Zero gravity lets a free object re-seat itself in the closing hand; on a table it cannot,
// and its weight loads the grasp while lifting, so grasps that hold only in zero gravity
// (edge and corner pinches, shallow fingertip grasps of heavy parts) are caught here.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "grasp_sim_internal.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::graspgen {
namespace {

constexpr const char* kSupportBody = "graspgen_support";
constexpr double kGravity = 9.81;             // m/s^2, on the object's bodies only
constexpr double kSupportClearance = -0.001;  // m: a hand touching the support is tested too
constexpr double kSimDescent = 0.02;          // m simulated above the grasp (the rest: geometry)
constexpr double kDescentCheck = 0.1;         // m of vertical descent checked geometrically
constexpr int kSettleSteps = 20;              // the object settles on the support
constexpr int kDescentSteps = 20;             // over kSimDescent
constexpr int kHoldSteps = 10;                // open hand at the grasp pose
constexpr double kLiftTime = 0.5;             // s for lift_height, at rest at both ends
constexpr int kLiftHoldSteps = 50;            // held up before the last check
constexpr double kSupportMaxPivot = 0.52;     // rad (30 degrees): see TestOnSupport

std::string Moved(double m, double rad) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f mm, %.1f deg", m * 1000, rad * 180 / std::numbers::pi);
  return buf;
}

}  // namespace

void AddSupport(mjSpec* spec) {
  mjsBody* body = mjs_addBody(mjs_findBody(spec, "world"), nullptr);
  mjs_setName(body->element, kSupportBody);
  body->mocap = 1;
  body->pos[2] = kSupportAway;
  mjsGeom* g = mjs_addGeom(body, nullptr);
  mjs_setName(g->element, kSupportBody);
  g->type = mjGEOM_BOX;
  g->size[0] = g->size[1] = 1;
  g->size[2] = kSupportHalfThickness;
  g->pos[2] = -kSupportHalfThickness;        // the top face through the body origin
  g->contype = g->conaffinity = 0x7fffffff;  // touches every collision geom
}

sim::ModelPtr SupportModel(const mjModel* m) {
  sim::ModelPtr copy(mj_copyModel(nullptr, m));
  mjOption& o = copy->opt;
  o.integrator = mjINT_IMPLICIT;
  o.cone = mjCONE_PYRAMIDAL;
  o.impratio = 1;
  o.noslip_iterations = 0;
  return copy;
}

bool GraspScene::AboveSupport(const Mat4& tcp) const {
  const Impl& s = *impl_;
  if (s.mode != Mode::kRigid || s.support_mocap < 0) return false;
  for (const OrientedBox& b : s.proxy.boxes) {
    for (int corner = 0; corner < 8; ++corner) {
      Vec3 p = b.center;
      for (int axis = 0; axis < 3; ++axis) {
        const double sign = (corner >> axis) & 1 ? 1.0 : -1.0;
        for (int row = 0; row < 3; ++row) p[row] += sign * b.half[axis] * b.rot[3 * row + axis];
      }
      const double z = tcp(2, 0) * p[0] + tcp(2, 1) * p[1] + tcp(2, 2) * p[2] + tcp(2, 3);
      if (z < s.support_z + kSupportClearance) return false;
    }
  }
  return true;
}

bool GraspScene::SupportClear(const Mat4& tcp) const {
  return AboveSupport(tcp) && !impl_->HandPathBlocked(tcp, {0, 0, 1}, kSimDescent, kDescentCheck);
}

std::string GraspScene::Impl::TestOnSupport(const Mat4& tcp_in_root, mjData* d,
                                            int64_t& steps) const {
  const mjModel* m = support_model.get();
  const auto step = [&] {
    mj_step(m, d);
    ++steps;
  };
  mj_resetData(m, d);
  mj_kinematics(m, d);
  const Mat4 start = BodyMat4(d, object);
  const Vec3 up{start(0, 2), start(1, 2), start(2, 2)};
  const auto raised = [&](const Mat4& pose, double h) {
    return Translate({h * up[0], h * up[1], h * up[2]}) * pose;
  };
  sim::PoseToMj(ToPose(start * Translate({0, 0, support_z})), d->mocap_pos + 3 * support_mocap,
                d->mocap_quat + 4 * support_mocap);
  std::vector<char> bodies(m->nbody, 0);
  for (int b = 1; b < m->nbody; ++b) {
    if (body_root[b] != object) continue;
    bodies[b] = 1;
    for (int k = 0; k < 3; ++k) d->xfrc_applied[6 * b + k] = -kGravity * m->body_mass[b] * up[k];
  }
  const Mat4 target = start * tcp_in_root;
  d->ctrl[actuator] = open_ctrl;
  PlaceHand(d, raised(target, kSimDescent));
  for (int k = 0; k < kSettleSteps; ++k) step();
  const Mat4 rest = BodyMat4(d, object);
  for (int k = 1; k <= kDescentSteps + kHoldSteps; ++k) {
    SetTcp(d, raised(target, kSimDescent * std::max(0, kDescentSteps - k) / kDescentSteps));
    step();
  }
  const auto moved = [&] {
    const Mat4 now = BodyMat4(d, object);
    return std::pair{TranslationDistance(rest, now), RotationAngle(rest, now)};
  };
  if (const auto [dist, angle] = moved(); dist > kApproachMotion || angle > kApproachTurn) {
    return "descent moved the object on the support: " + Moved(dist, angle);
  }
  steps += Close(m, d, [&] { return moved().first > 0.02; });
  if (const int sides = FingerContacts(d, bodies); sides != 3) {
    const auto [dist, angle] = moved();
    return std::string(sides == 0 ? "not held after closing on the support"
                                  : "one finger after closing on the support") +
           ": object moved " + Moved(dist, angle);
  }
  const Mat4 object_in_tcp = InverseRigid(sim::SiteMat4(d, site)) * BodyMat4(d, object);
  const Mat4 tcp_in_object = InverseRigid(object_in_tcp);
  // Slip is measured where the fingers hold: how far the object's point that was at the TCP
  // has moved from it. An object held far from its centre of mass (a wide bowl by its rim)
  // pivots about that point as it leaves the support and hangs; its far side then moves by
  // the lever times the angle, which is not slip, and the data engine still lifts it. It may
  // turn up to kSupportMaxPivot.
  const double max_pivot = std::max(params.max_slip_angle, kSupportMaxPivot);
  const auto slip = [&]() -> std::string {
    const Mat4 now = InverseRigid(sim::SiteMat4(d, site)) * BodyMat4(d, object);
    const Vec3 drift = Translation(now * tcp_in_object);
    const double dist = std::sqrt(drift[0] * drift[0] + drift[1] * drift[1] + drift[2] * drift[2]);
    const double angle = RotationAngle(object_in_tcp, now);
    if (dist > params.max_slip || angle > max_pivot) {
      return "slipped in the hand while lifting from the support: " + Moved(dist, angle);
    }
    return {};
  };
  const int lift = std::max(4, static_cast<int>(std::lround(kLiftTime / params.timestep)));
  for (int k = 1; k <= lift + kLiftHoldSteps; ++k) {
    const double u = static_cast<double>(std::min(k, lift)) / lift;
    const double s = u - std::sin(2 * std::numbers::pi * u) / (2 * std::numbers::pi);
    SetTcp(d, raised(target, params.lift_height * s));
    step();

    if (k % kSlipEvery == 0) {
      if (std::string r = slip(); !r.empty()) return r;
    }
  }
  if (const int sides = FingerContacts(d, bodies); sides != 3) {
    return std::string(sides == 0 ? "dropped while lifting from the support"
                                  : "held by one finger after lifting from the support");
  }
  return slip();
}

}  // namespace mlspaces::graspgen
