// Grasp generation, candidates: systematic antipodal grasp candidates on a mesh (the
// MolmoSpaces generator's candidate space, docs/graspgen.md): surface points by area, 7
// standoffs, 12 half-circle rolls, the visibility ray, the open-hand collision filter against a
// gripper proxy, and the antipodal quality and contact depth from the closing rays.
//
// Frames. Poses are TCP poses in the mesh's frame (the object body frame for AssetCollisionMesh)
// in the unified convention: +z = approach (palm toward object), fingers open and close along
// +-y, origin between the finger pads. The original generates in a hand frame that closes along
// x; this converts by a +90 deg turn about z.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <string>
#include <vector>

#include "mlspaces/core/transform.h"
#include "mlspaces/graspgen/mesh.h"

namespace mlspaces::robots {
struct RobotSpec;
}  // namespace mlspaces::robots

namespace mlspaces::graspgen {

/// The open gripper as boxes in the TCP frame, and its closing rays.
struct MLSPACES_API GripperProxy {
  std::string name;
  /// Palm, fingers and pads of the open hand (box frames in the TCP frame).
  std::vector<OrientedBox> boxes;
  /// Half the distance between the two closing-ray origins (each finger's centre, on +-y).
  double finger_offset = 0;
  /// TCP-frame z of the closing-ray levels, palm side first (contact depth 0 -> 1).
  std::vector<double> ray_levels;
};

/// The open gripper of `robot`, read from its MJCF at qpos0 (the fingers open): a box per
/// collision geom below the gripper body (the geom's local bounding box), in the TCP site
/// frame; closing rays from the two finger pads' centres (finger_offset: their mean |y|), at
/// 20 levels over the pads' common extent along the TCP z. @throws Error naming the robot
/// description and its field (gripper.body, tcp_site, gripper.finger_pads) when one is
/// missing, the gripper has no collision geom, or the pads do not face each other across y.
MLSPACES_API GripperProxy GripperProxyOf(const robots::RobotSpec& robot);

/// GripperProxyOf(assets/robots/franka_droid), the Robotiq 2F-85-like gripper: coupling,
/// housing, driver links, pads and pad backs at driver angle 0.
MLSPACES_API GripperProxy FrankaDroidGripperProxy();

/// The candidate space (defaults: the MolmoSpaces generator's, spec section 2.4.2).
struct MLSPACES_API CandidateParams {
  double surface_density = 2.5e-5;  ///< m^2 of surface per sampled point
  double standoff_min = 0.101;      ///< hand origin to surface point (m)
  double standoff_max = 0.174;
  double standoff_density = 0.01;  ///< m; count = max(1, floor(range / density))
  double roll_step_deg = 15;       ///< rolls 0, step, ... < 180
  /// Hand origin -> TCP along the approach: TCP = point + (standoff - tcp_offset) * normal.
  double tcp_offset = 0.155;
  double min_quality = 0.005;  ///< antipodal cosine threshold
  int threads = 0;             ///< <= 0: all cores; the result does not depend on it
};

/// One kept candidate.
struct MLSPACES_API GraspCandidate {
  Mat4 tcp;  ///< TCP pose in the mesh frame (unified convention)
  double quality = 0;
  double depth = 0;  ///< mean contact level / (levels - 1): 0 near the palm, 1 at the tip
  Vec3 point{0, 0, 0};
  Vec3 normal{0, 0, 0};
  double roll = 0;  ///< rad, about the approach axis
  double standoff = 0;
};

/// Counts per stage, for summaries and tests.
struct MLSPACES_API CandidateStats {
  size_t points = 0;          ///< surface samples
  size_t raw = 0;             ///< points x standoffs x rolls
  size_t visible = 0;         ///< passing the visibility ray
  size_t collision_free = 0;  ///< visible and not touching the open hand
  size_t kept = 0;            ///< collision free with quality >= min_quality
};

struct MLSPACES_API CandidateSet {
  std::vector<GraspCandidate>
      candidates;  ///< points in sampling order; per point rolls, then standoffs
  CandidateStats stats;
};

/// The standoff values of `params` (evenly spaced, ends included).
MLSPACES_API std::vector<double> Standoffs(const CandidateParams& params);
/// The roll values (rad) of `params`.
MLSPACES_API std::vector<double> Rolls(const CandidateParams& params);

/// TCP pose (unified convention) for surface point p with outward normal n, roll and standoff.
MLSPACES_API Mat4 CandidateTcp(const Vec3& p, const Vec3& n, double roll, double standoff,
                               double tcp_offset);

/// Antipodal quality and contact depth of a TCP pose from the closing rays (spec 2.4.4):
/// quality 0 when a side has no hit within 2 * finger_offset or a contact faces the wrong way.
MLSPACES_API std::pair<double, double> AntipodalQuality(const MeshBvh& bvh,
                                                        const GripperProxy& gripper,
                                                        const Mat4& tcp);

/// The TCP moved along its closing axis (y) so that both fingers' closing rays meet the mesh
/// at the same distance: both fingers then touch together instead of the first pushing the
/// object toward the second. `tcp` itself when a finger's rays hit nothing.
MLSPACES_API Mat4 CenteredTcp(const MeshBvh& bvh, const GripperProxy& gripper, const Mat4& tcp);

/// True when an open-hand box touches the mesh at this TCP pose.
MLSPACES_API bool HandCollides(const MeshBvh& bvh, const GripperProxy& gripper, const Mat4& tcp);

/// All candidates of a mesh, filtered and scored; deterministic for (mesh, gripper, params,
/// seed) whatever params.threads. Seed it with DeriveSeed(run_seed, {HashString(uid)}).
/// `obstacles` (optional): the open hand must not touch that mesh either (joints.h).
MLSPACES_API CandidateSet GenerateCandidates(const MeshBvh& bvh, const GripperProxy& gripper,
                                             const CandidateParams& params, uint64_t seed,
                                             const MeshBvh* obstacles = nullptr);

}  // namespace mlspaces::graspgen
