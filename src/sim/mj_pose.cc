#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::sim {

Pose PoseFromMj(const mjtNum* pos, const mjtNum* quat) {
  return {{pos[0], pos[1], pos[2]}, {quat[0], quat[1], quat[2], quat[3]}};
}

void PoseToMj(const Pose& pose, mjtNum* pos, mjtNum* quat) {
  for (int i = 0; i < 3; ++i) pos[i] = pose.pos[i];
  for (int i = 0; i < 4; ++i) quat[i] = pose.quat[i];
}

Mat4 FrameToMat4(const mjtNum* pos, const mjtNum* xmat) {
  Rot3 rot;
  for (int i = 0; i < 9; ++i) rot[i] = xmat[i];
  return ToMat4({pos[0], pos[1], pos[2]}, rot);
}

Pose BodyPose(const mjData* d, int body) {
  return PoseFromMj(d->xpos + 3 * body, d->xquat + 4 * body);
}

Mat4 SiteMat4(const mjData* d, int site) {
  return FrameToMat4(d->site_xpos + 3 * site, d->site_xmat + 9 * site);
}

Mat4 GeomMat4(const mjData* d, int geom) {
  return FrameToMat4(d->geom_xpos + 3 * geom, d->geom_xmat + 9 * geom);
}

Mat4 GeomBoxFrame(const mjModel* m, const mjData* d, int geom, Vec3* half) {
  const mjtNum* aabb = m->geom_aabb + 6 * geom;  // centre, then half sizes, in the geom frame
  const mjtNum* r = d->geom_xmat + 9 * geom;
  Mat4 t = GeomMat4(d, geom);
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 3; ++i) t(k, 3) += r[3 * k + i] * aabb[i];
  }
  for (int i = 0; i < 3; ++i) (*half)[i] = aabb[3 + i];
  return t;
}

}  // namespace mlspaces::sim
