#include "mlspaces/sim/gravity_compensation.h"

#include <stdexcept>
#include <string>

namespace mlspaces::sim {

void ApplyGravityCompensation(const mjModel* m, mjData* d, std::span<const int> dofs) {
  const bool gravity_on = (m->opt.disableflags & mjDSBL_GRAVITY) == 0;
  const mjtNum* g = m->opt.gravity;
  for (const int j : dofs) {
    if (j < 0 || j >= m->nv) {
      throw std::out_of_range("ApplyGravityCompensation: dof " + std::to_string(j) +
                              " outside [0, " + std::to_string(m->nv) + ")");
    }
    if (!gravity_on) {
      d->qfrc_applied[j] = 0;
      continue;
    }
    const int body = m->dof_bodyid[j];
    const mjtNum mass = m->body_subtreemass[body];
    const mjtNum* com = d->subtree_com + 3 * body;
    const mjtNum* ref = d->subtree_com + 3 * m->body_rootid[body];
    const mjtNum* cdof = d->cdof + 6 * j;  // [rotation, translation at ref]
    const mjtNum force[3] = {mass * g[0], mass * g[1], mass * g[2]};
    mjtNum arm[3];
    mju_sub3(arm, com, ref);
    mjtNum torque[3];
    mju_cross(torque, arm, force);
    d->qfrc_applied[j] = -(mju_dot3(cdof, torque) + mju_dot3(cdof + 3, force));
  }
}

std::vector<int> SubtreeDofs(const mjModel* m, int body) {
  if (body < 0 || body >= m->nbody) {
    throw std::out_of_range("SubtreeDofs: body " + std::to_string(body) + " outside [0, " +
                            std::to_string(m->nbody) + ")");
  }
  std::vector<int> dofs;
  for (int j = 0; j < m->nv; ++j) {
    for (int b = m->dof_bodyid[j];; b = m->body_parentid[b]) {
      if (b == body) {
        dofs.push_back(j);
        break;
      }
      if (b == 0) break;
    }
  }
  return dofs;
}

}  // namespace mlspaces::sim
