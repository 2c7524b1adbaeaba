#include "mlspaces/datagen/tasks/pick/success.h"

#include <algorithm>
#include <string>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {
namespace {

std::string GeomName(const mjModel* m, int geom) {
  const char* name = mj_id2name(m, mjOBJ_GEOM, geom);
  return name != nullptr && name[0] != '\0' ? std::string(name) : "geom " + std::to_string(geom);
}

}  // namespace

bool IsRobotBody(const mjModel* m, int body, std::string_view robot_prefix) {
  if (body <= 0 || body >= m->nbody) return false;  // the world is never the robot
  const char* name = mj_id2name(m, mjOBJ_BODY, body);
  if (name != nullptr && std::string_view(name).starts_with(robot_prefix)) return true;
  const std::string root_name = std::string(robot_prefix) + "base";
  const int root = mj_name2id(m, mjOBJ_BODY, root_name.c_str());
  return root > 0 && sim::InSubtree(m, body, root);
}

PickSuccess EvaluatePickSuccess(const mjModel* m, const mjData* d, int object_body, double start_z,
                                std::string_view robot_prefix, double min_lift) {
  if (object_body <= 0 || object_body >= m->nbody) {
    throw UsageError("EvaluatePickSuccess: object body id " + std::to_string(object_body) +
                     " is not a body of the model (1.." + std::to_string(m->nbody - 1) + ")");
  }
  if (!(min_lift >= 0)) throw UsageError("EvaluatePickSuccess: min_lift must be >= 0");
  if (robot_prefix.empty()) throw UsageError("EvaluatePickSuccess: empty robot prefix");

  PickSuccess r;
  r.lift = d->xpos[3 * object_body + 2] - start_z;
  r.lifted = r.lift >= min_lift;

  double best_support = 0.5;  // normal z below this is a side contact, not support
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    const bool in1 = sim::InSubtree(m, m->geom_bodyid[c.geom1], object_body);
    const bool in2 = sim::InSubtree(m, m->geom_bodyid[c.geom2], object_body);
    if (in1 == in2) continue;  // not the object's, or inside the object
    const int other = in1 ? c.geom2 : c.geom1;
    // frame[0..2] is the normal, pointing from geom1 to geom2; flip it to point into the object.
    const double up = in2 ? c.frame[2] : -c.frame[2];
    if (up >= best_support) {
      best_support = up;
      r.supporting_geom = other;
    }
    if (IsRobotBody(m, m->geom_bodyid[other], robot_prefix)) {
      ++r.robot_contacts;
    } else {
      ++r.other_contacts;
      std::string name = GeomName(m, other);
      if (std::find(r.non_robot_geoms.begin(), r.non_robot_geoms.end(), name) ==
          r.non_robot_geoms.end()) {
        r.non_robot_geoms.push_back(std::move(name));
      }
    }
  }
  r.only_robot_contact = r.other_contacts == 0 && r.robot_contacts > 0;
  r.success = r.lifted && r.only_robot_contact;

  const bool robot_support =
      r.supporting_geom >= 0 && IsRobotBody(m, m->geom_bodyid[r.supporting_geom], robot_prefix) &&
      m->geom_group[r.supporting_geom] >= 0 && m->geom_group[r.supporting_geom] <= 2;
  if (r.supporting_geom < 0 || robot_support) r.reward = std::clamp(r.lift, 0.0, 1000.0);
  return r;
}

}  // namespace mlspaces::datagen
