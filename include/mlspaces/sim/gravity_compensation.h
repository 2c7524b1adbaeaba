// Gravity compensation for MuJoCo 2.2.2, which lacks MuJoCo 3's body `gravcomp` attribute.
//
// MolmoSpaces sets gravcomp="1" on every body of the robot (everything under fr3_link0): each
// such body gets the force -m g at its centre of mass, mapped to joint space. For a body tree
// whose only bodies are those robot bodies (true of a robot on a mocap base: grasped objects
// are not in its kinematic tree), that equals, per dof j,
//   tau_j = -(J_j^T sum_{b in subtree(j)} m_b g)
//         = -(cdof_lin_j . (M_j g) + cdof_rot_j . ((c_j - r_j) x (M_j g))),
// with M_j / c_j the mass / centre of mass of the subtree of the dof's body and r_j the centre
// of mass of the dof's kinematic tree (the point MuJoCo's cdof refers to). This is the gravity
// part of qfrc_bias, computed without the velocity (Coriolis/centrifugal) part.
#pragma once

#include <span>
#include <vector>

#include <mujoco/mujoco.h>

namespace mlspaces::sim {

/// Writes the gravity-cancelling generalized force of each listed dof into d->qfrc_applied
/// (overwriting those entries; other entries are untouched), so calling it once per step does
/// not accumulate. Needs the position stage of `d` to be current (mj_kinematics + mj_comPos;
/// mj_step1, mj_fwdPosition and mj_forward all do that): call it between mj_step1 and mj_step2,
/// or before mj_step (then it uses the previous step's positions). Writes zeros when gravity is
/// disabled. @throws std::out_of_range for a dof index outside [0, nv).
void ApplyGravityCompensation(const mjModel* m, mjData* d, std::span<const int> dofs);

/// The dofs of every joint in the subtree of `body` (the body itself included), ascending.
/// E.g. SubtreeDofs(m, id of "robot_0/fr3_link0") = the arm and gripper dofs, MolmoSpaces'
/// gravcomp set. @throws std::out_of_range for a bad body id.
std::vector<int> SubtreeDofs(const mjModel* m, int body);

}  // namespace mlspaces::sim
