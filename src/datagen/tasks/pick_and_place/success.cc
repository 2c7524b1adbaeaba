// Pick-and-place success (tasks/pick_and_place/success.h).
#include "mlspaces/datagen/tasks/pick_and_place/success.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "mlspaces/core/error.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/datagen/tasks/pick/success.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {
namespace {

constexpr double kCos30 = 0.8660254037844387;

int RootOf(const mjModel* m, int body) {
  while (body > 0 && m->body_parentid[body] != 0) body = m->body_parentid[body];
  return body;
}

// The root body the object rests on (the supporting geom's), or -1.
int SupportRoot(const mjModel* m, const mjData* d, int body, std::string_view prefix) {
  const PickSuccess p = EvaluatePickSuccess(m, d, body, 0, prefix, 0.0);
  return p.supporting_geom < 0 ? -1 : RootOf(m, m->geom_bodyid[p.supporting_geom]);
}

}  // namespace

std::array<Vec3, 2> SubtreeAabb(const mjModel* m, const mjData* d, int body) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::array<Vec3, 2> out{Vec3{kInf, kInf, kInf}, Vec3{-kInf, -kInf, -kInf}};
  if (body <= 0) return out;  // the world is no object's subtree
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_type[g] == mjGEOM_PLANE || !sim::InSubtree(m, m->geom_bodyid[g], body)) continue;
    const mjtNum* a = m->geom_aabb + 6 * g;  // centre, half sizes, geom frame
    const mjtNum* r = d->geom_xmat + 9 * g;
    for (int i = 0; i < 3; ++i) {
      const double c =
          d->geom_xpos[3 * g + i] + r[3 * i] * a[0] + r[3 * i + 1] * a[1] + r[3 * i + 2] * a[2];
      const double h =
          std::abs(r[3 * i]) * a[3] + std::abs(r[3 * i + 1]) * a[4] + std::abs(r[3 * i + 2]) * a[5];
      out[0][i] = std::min(out[0][i], c - h);
      out[1][i] = std::max(out[1][i], c + h);
    }
  }
  return out;
}

Json PlaceVerdict::Info(TaskType type, int64_t step) const {
  const Json disp = Json::array({receptacle_pos_displacement[0], receptacle_pos_displacement[1],
                                 receptacle_pos_displacement[2]});
  if (type == TaskType::kPickAndPlaceNextTo) {
    return Json{{"success", success},
                {"within_distance_range", within_distance_range},
                {"on_same_surface", on_same_surface},
                {"min_surface_gap", min_surface_gap},
                {"receptacle_pos_displacement", disp},
                {"receptacle_rot_displacement", receptacle_rot_displacement},
                {"episode_step", step}};
  }
  return Json{{"position_error", position_error},
              {"success", success},
              {"supported_by_receptacle", supported_by_receptacle},
              {"supported_by_carry_forward", supported_by_carry_forward},
              {"carry_forward_pos_diff", carry_forward_pos_diff},
              {"carry_forward_rot_diff", carry_forward_rot_diff},
              {"robot_contact", robot_contact},
              {"receptacle_pos_displacement", disp},
              {"receptacle_rot_displacement", receptacle_rot_displacement},
              {"receptacle_tilt_displacement", receptacle_tilt_displacement},
              {"episode_step", step}};
}

PlaceJudge::PlaceJudge(const mjModel* m, int object_body, int receptacle_body,
                       const Pose& receptacle_start, TaskType type, const TaskConfig& config,
                       std::string robot_prefix)
    : m_(m),
      object_(object_body),
      receptacle_(receptacle_body),
      receptacle_start_(ToMat4(receptacle_start)),
      type_(type),
      config_(config),
      prefix_(std::move(robot_prefix)) {
  if (object_body <= 0 || object_body >= m->nbody || receptacle_body <= 0 ||
      receptacle_body >= m->nbody) {
    throw UsageError("PlaceJudge: bad object or receptacle body id");
  }
}

PlaceVerdict PlaceJudge::Evaluate(const mjData* d) {
  const mjModel* m = m_;
  PlaceVerdict v;
  const Mat4 rec = ToMat4(sim::BodyPose(d, receptacle_));
  const Mat4 obj = ToMat4(sim::BodyPose(d, object_));
  const std::array<Vec3, 2> rb = SubtreeAabb(m, d, receptacle_);
  const std::array<Vec3, 2> ob = SubtreeAabb(m, d, object_);
  // Receptacle displacement: translation in its start frame, full angle, tilt of its z axis.
  const Mat4 rel = InverseRigid(receptacle_start_) * rec;
  v.receptacle_pos_displacement = Translation(rel);
  v.receptacle_rot_displacement = RotationAngle(receptacle_start_, rec);
  {
    // The angle by which the start-to-now rotation moves world +z.
    const Mat4 turn = rec * InverseRigid(receptacle_start_);
    v.receptacle_tilt_displacement = std::acos(std::clamp(turn(2, 2), -1.0, 1.0));
  }
  const double moved =
      std::sqrt(v.receptacle_pos_displacement[0] * v.receptacle_pos_displacement[0] +
                v.receptacle_pos_displacement[1] * v.receptacle_pos_displacement[1] +
                v.receptacle_pos_displacement[2] * v.receptacle_pos_displacement[2]);

  if (type_ == TaskType::kPickAndPlaceNextTo) {
    double gap2 = 0;
    for (int i = 0; i < 2; ++i) {
      const double g = std::max({0.0, ob[0][i] - rb[1][i], rb[0][i] - ob[1][i]});
      gap2 += g * g;
    }
    v.min_surface_gap = std::sqrt(gap2);
    v.within_distance_range = v.min_surface_gap >= config_.min_surface_to_surface_gap &&
                              v.min_surface_gap <= config_.max_surface_to_surface_gap + 0.01;
    const int so = SupportRoot(m, d, object_, prefix_);
    const int sr = SupportRoot(m, d, receptacle_, prefix_);
    v.on_same_surface = so >= 0 && so == sr;
    v.success = v.within_distance_range && v.on_same_surface &&
                moved <= config_.max_place_receptacle_pos_displacement &&
                v.receptacle_rot_displacement <= config_.max_place_receptacle_rot_displacement;
    v.reward = std::exp(-v.min_surface_gap);
    return v;
  }

  // (a) contact forces of the receptacle on the object; robot contact.
  double force[3] = {0, 0, 0};
  bool low_contact = false;
  const double centre_z = 0.5 * (ob[0][2] + ob[1][2]);
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    const int b1 = m->geom_bodyid[con.geom1], b2 = m->geom_bodyid[con.geom2];
    const bool o1 = sim::InSubtree(m, b1, object_), o2 = sim::InSubtree(m, b2, object_);
    if (o1 == o2) continue;
    const int other = o1 ? b2 : b1;
    if (IsRobotBody(m, other, prefix_)) v.robot_contact = true;
    if (!sim::InSubtree(m, other, receptacle_)) continue;
    mjtNum f[6];
    mj_contactForce(m, d, c, f);
    // The contact force acts on geom2 along +normal (frame rows: normal, tangents).
    const double sign = o2 ? 1.0 : -1.0;
    for (int i = 0; i < 3; ++i) {
      force[i] += sign * (con.frame[i] * f[0] + con.frame[3 + i] * f[1] + con.frame[6 + i] * f[2]);
    }
    const double nz = sign * con.frame[2];  // normal pointing into the object
    if (con.pos[2] < centre_z && nz >= kCos30) low_contact = true;
  }
  const double fnorm = std::sqrt(force[0] * force[0] + force[1] * force[1] + force[2] * force[2]);
  const double weight = m->body_subtreemass[object_] * std::abs(m->opt.gravity[2]);
  const bool by_force = fnorm > 1e-6 && force[2] >= kCos30 * fnorm &&
                        force[2] >= config_.receptacle_supported_weight_frac * weight;
  // (b) geometry.
  const double ocx = 0.5 * (ob[0][0] + ob[1][0]), ocy = 0.5 * (ob[0][1] + ob[1][1]);
  const double rtop = rb[1][2], rh = rb[1][2] - rb[0][2];
  const bool inside = ocx >= rb[0][0] && ocx <= rb[1][0] && ocy >= rb[0][1] && ocy <= rb[1][1] &&
                      ob[0][2] >= rtop - 0.5 * rh && ob[0][2] <= rtop + 0.01;
  bool supported = by_force || low_contact || inside;
  // (c) carry-forward.
  const Mat4 obj_in_rec = InverseRigid(rec) * obj;
  if (supported) {
    memory_.push_back(obj_in_rec);
    v.supported_by_receptacle = true;
  } else if (!memory_.empty()) {
    double best_pos = std::numeric_limits<double>::infinity(), best_rot = best_pos;
    for (const Mat4& past : memory_) {
      const double dp = TranslationDistance(past, obj_in_rec);
      const double dr = RotationAngle(past, obj_in_rec);
      if (dp <= 0.005 && dr <= 10.0 * std::numbers::pi / 180.0) {
        v.supported_by_carry_forward = true;
      }
      if (dp < best_pos) {
        best_pos = dp;
        best_rot = dr;
      }
    }
    v.carry_forward_pos_diff = best_pos;
    v.carry_forward_rot_diff = best_rot;
    v.supported_by_receptacle = v.supported_by_carry_forward;
  }
  // position_error: receptacle AABB centre to the object's AABB (0 inside).
  double e2 = 0;
  for (int i = 0; i < 3; ++i) {
    const double c = 0.5 * (rb[0][i] + rb[1][i]);
    const double g = std::max({0.0, ob[0][i] - c, c - ob[1][i]});
    e2 += g * g;
  }
  v.position_error = std::sqrt(e2);
  double dc2 = 0;
  for (int i = 0; i < 3; ++i) {
    const double c = 0.5 * (rb[0][i] + rb[1][i]);
    dc2 += (obj(i, 3) - c) * (obj(i, 3) - c);
  }
  v.reward = std::exp(-std::sqrt(dc2));
  v.success = v.supported_by_receptacle && !v.robot_contact &&
              moved <= config_.max_place_receptacle_pos_displacement &&
              v.receptacle_tilt_displacement <= config_.max_place_receptacle_rot_displacement;
  return v;
}

std::string PlaceDescription(TaskType type, const std::string& pickup, const std::string& place,
                             const std::string& color) {
  if (type == TaskType::kPickAndPlaceNextTo) {
    return "Pick up the " + pickup + " and place it next to the " + place;
  }
  if (type == TaskType::kPickAndPlaceColor) {
    std::string c = color.empty() ? std::string("colored") : color;
    std::replace(c.begin(), c.end(), '_', ' ');
    return "Pick up the " + pickup + " and place it in or on the " + c + " " + place;
  }
  return "Pick up the " + pickup + " and place it in or on the " + place;
}

}  // namespace mlspaces::datagen
