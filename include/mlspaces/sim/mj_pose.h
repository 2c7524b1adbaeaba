// The one place where MuJoCo's pose arrays become mlspaces poses and back: positions
// (xpos, mocap_pos, a free joint's qpos[0:3]) with quaternions (xquat, mocap_quat,
// qpos[3:7]; w, x, y, z as Pose) or with row-major rotation matrices (xmat).
#pragma once

#include "mlspaces/core/export.h"

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"

namespace mlspaces::sim {

/// The pose of MuJoCo's pos[3] + quat[4] arrays, copied as they are.
MLSPACES_API Pose PoseFromMj(const mjtNum* pos, const mjtNum* quat);
/// Writes a pose into MuJoCo's pos[3] + quat[4] arrays, as it is.
MLSPACES_API void PoseToMj(const Pose& pose, mjtNum* pos, mjtNum* quat);
/// The matrix of MuJoCo's pos[3] + row-major xmat[9] (e.g. site_xpos + site_xmat).
MLSPACES_API Mat4 FrameToMat4(const mjtNum* pos, const mjtNum* xmat);

/// World pose of a body after a forward pass (xpos, xquat).
MLSPACES_API Pose BodyPose(const mjData* d, int body);
/// World matrix of a site / geom after a forward pass (xpos, xmat).
MLSPACES_API Mat4 SiteMat4(const mjData* d, int site);
MLSPACES_API Mat4 GeomMat4(const mjData* d, int geom);
/// The frame of geom `geom`'s bounding box (MuJoCo's geom_aabb: the geom's axes, moved to the
/// box centre) in world coordinates after a forward pass; `half` (not null) gets the box's half
/// sizes along those axes.
MLSPACES_API Mat4 GeomBoxFrame(const mjModel* m, const mjData* d, int geom, Vec3* half);

}  // namespace mlspaces::sim
