// The open hand as boxes, shared by GripperProxyOf (gripper_proxy.cc) and GraspScene
// (grasp_sim.cc). Not installed.
#pragma once

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"
#include "mlspaces/graspgen/mesh.h"

namespace mlspaces::graspgen {

/// Geom `g`'s local bounding box (geom_aabb) as an oriented box in the frame whose inverse
/// pose is `world_to_frame`, at the positions in `d` (after mj_kinematics).
OrientedBox GeomBox(const mjModel* m, const mjData* d, int g, const Mat4& world_to_frame);

}  // namespace mlspaces::graspgen
