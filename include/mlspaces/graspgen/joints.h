// Grasp generation, articulated objects: the joints of an asset that grasps can open (hinge and
// slide), the handle geometry of each, and candidates on that handle (spec section 3.2-3.3,
// docs/graspgen.md). The asset file is only read, never modified.
//
// Frames. Everything is in the frame of the body that owns the joint (model.jnt_bodyid), at the
// model's qpos0: handle mesh, whole-object mesh, candidates' TCP poses and the joint's axis and
// anchor. That is the frame joint grasps are stored in (spec 1.5).
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/core/transform.h"
#include "mlspaces/graspgen/antipodal.h"
#include "mlspaces/graspgen/mesh.h"

namespace mlspaces::graspgen {

/// One hinge or slide joint of an asset and what the grasp test needs to move it.
struct MLSPACES_API JointTarget {
  std::string joint;                  ///< joint name as in the MJCF (compiled model name)
  std::string body;                   ///< the body that owns the joint
  bool hinge = true;                  ///< false: slide
  Vec3 axis{0, 0, 1};                 ///< unit axis, joint-body frame
  Vec3 anchor{0, 0, 0};               ///< joint anchor, joint-body frame
  bool limited = false;               ///< the MJCF gives a range
  std::array<double, 2> range{0, 0};  ///< rad or m (the compiled model's range when limited)
  /// The signed travel the test sweeps from qpos0 (rad or m): the range end farther from
  /// qpos0 when limited; unlimited: +pi/2 for a hinge, +the body's extent along the axis
  /// (at most 0.4 m) for a slide.
  double travel = 0;
  /// Names of the handle geoms (leaf-most collision geoms of the joint body's subtree).
  std::vector<std::string> handle_geoms;
  /// The handle geoms as one mesh (joint-body frame); empty when there is no handle geometry.
  TriMesh handle;
  /// Every collision geom of the asset's root body subtree (joint-body frame, qpos0).
  TriMesh object;
};

/// The hinge and slide joints of the asset's first top-level body subtree, in model order,
/// with their handles. Free and ball joints are skipped. @throws Error (asset file) when the
/// asset does not compile or has no hinge/slide joint; a joint with no handle geometry is
/// returned with an empty `handle` (the caller reports it per joint).
MLSPACES_API std::vector<JointTarget> FindJointTargets(const std::filesystem::path& asset_file);

/// Candidates on the joint's handle: GenerateCandidates' candidate space on `target.handle`,
/// with the open-hand collision test against the whole object (`target.object`) as well, so
/// no candidate touches the cabinet body, door or drawer front. TCP poses in the joint-body
/// frame. Deterministic for the seed whatever params.threads. @throws Error for an empty handle.
MLSPACES_API CandidateSet GenerateJointCandidates(const JointTarget& target,
                                                  const GripperProxy& gripper,
                                                  const CandidateParams& params, uint64_t seed);

}  // namespace mlspaces::graspgen
