// Grasp generation, simulation: the robot's gripper floating in a zero-gravity MuJoCo scene with
// the object, and the tests a candidate must pass to be kept (spec sections 2.5 and 3.4, with
// the original's bugs fixed; docs/graspgen.md).
//
// One model is compiled per object (and per joint test scene) and reused for every candidate:
// each worker thread owns one mjData, reset before each candidate (mj_resetData), never a
// recompile. A candidate's outcome depends only on the model and the candidate, so the results,
// and which candidates are kept, do not depend on the thread count.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"
#include "mlspaces/graspgen/antipodal.h"
#include "mlspaces/graspgen/joints.h"
#include "mlspaces/robots/robot_spec.h"

namespace mlspaces::graspgen {

/// Simulation settings. Defaults are ours (docs/graspgen.md explains each against the
/// original's 0.3 m / 6 s approach, 3 x 2 shakes of 0.1 m at 4 s period and a 10 s twist).
struct MLSPACES_API SimParams {
  double timestep = 0.002;  ///< s, as the original's scene
  int threads = 0;          ///< <= 0: all cores; results do not depend on it
  // Rigid test
  double approach_distance = 0.3;  ///< m, start of the approach behind the grasp
  double shake_amplitude = 0.045;  ///< m, per world axis (original: 0.1)
  double shake_period = 0.4;       ///< s, one at-rest-to-rest period per axis (orig.: 2 x 4 s)
  double twist_angle = 3.141592653589793;  ///< rad turned about the approach (original: 2 pi)
  double twist_period = 1.0;               ///< s, for twist_angle (original: 10 s)
  double max_slip = 0.01;                  ///< m, object drift in the hand (TCP frame) that fails
  double max_slip_angle = 0.2;             ///< rad, object turn in the hand that fails
  /// Rigid grasps whose open hand clears the object's support plane (the plane under its
  /// lowest point, perpendicular to its body z) are also tested as a pick from that support:
  /// gravity on, vertical descent, close, lift by lift_height (docs/graspgen.md).
  bool support_test = true;
  double lift_height = 0.1;  ///< m, along the object's body z
  // Articulated test
  double joint_approach_distance = 0.6;    ///< m
  double max_approach_disturbance = 0.01;  ///< rad or m the approach may move the joint
  double min_travel_fraction = 0.7;        ///< of |JointTarget::travel|, forward sweep
};

/// What testing one candidate found.
struct MLSPACES_API SimOutcome {
  bool success = false;
  /// Empty on success, else a short stable reason, measured numbers after a ':' ("approach
  /// path blocked", "not held after closing: object moved 22.3 mm, 18.3 deg", "lost during
  /// shake x", "slipped in the hand: 12.4 mm during twist", "joint moved too little: 23% of its
  /// travel" ...); ReasonClass gives the part before the ':'.
  std::string reason;
  /// The TCP pose measured after closing: in the object body frame (rigid) or the frame of
  /// the body owning the joint (articulated). Valid when success.
  Mat4 tcp{};
  int64_t steps = 0;  ///< mj_step calls spent on this candidate
};

/// Testing candidates in order until enough succeed.
struct MLSPACES_API SimRun {
  /// Indices (into the candidates) of the successes, in test order, at most max_success.
  std::vector<size_t> accepted;
  /// Their measured TCP poses (SimOutcome::tcp), same order.
  std::vector<Mat4> poses;
  size_t tested = 0;  ///< candidates whose outcome counts (a prefix of the order)
  int64_t steps = 0;  ///< mj_step calls over the tested prefix
  std::map<std::string, size_t> failures;  ///< reason (number-free class) -> count
};

/// The number-free class of a failure reason, the key of SimRun::failures: the text before
/// its first ':' (reasons put their measured numbers after one).
MLSPACES_API std::string ReasonClass(const std::string& reason);

/// Called from the calling thread now and then: candidates tested, accepted so far.
using SimProgress = std::function<void(size_t tested, size_t accepted)>;

/// The gripper of `robot` (its `gripper.body` subtree, actuator, pads and TCP site) floating
/// as a mocap-driven hand with `asset_file`'s object, in zero gravity. Compiled once.
class MLSPACES_API GraspScene {
 public:
  enum class Mode { kRigid, kArticulated };
  /// Rigid: the object is free to move (its own free joint, or one added). Articulated: the
  /// object's root is fixed to the world (free joints dropped in memory; the file is not
  /// touched). @throws Error (asset or robot file) when composing or compiling fails.
  GraspScene(const std::filesystem::path& asset_file, const robots::RobotSpec& robot, Mode mode,
             const SimParams& params);
  ~GraspScene();
  GraspScene(const GraspScene&) = delete;
  GraspScene& operator=(const GraspScene&) = delete;

  /// The compiled model; valid while the scene lives.
  const mjModel* model() const;
  /// The object's collision geometry (its root body's subtree, in the root body frame at
  /// qpos0: what AssetCollisionMesh gives for the file), from this scene's compiled model;
  /// valid while the scene lives.
  const MeshBvh& object_mesh() const;

  /// Rigid test of one candidate (TCP pose in the object body frame) on `data` (an mjData of
  /// model(), reset here).
  SimOutcome TestRigid(const Mat4& tcp, mjData* data) const;
  /// True when the open hand at `tcp` (object body frame) clears the object's support plane
  /// (the plane under its lowest point, perpendicular to its body z; rigid scenes).
  bool AboveSupport(const Mat4& tcp) const;
  /// AboveSupport, and the hand's vertical descent onto `tcp` does not touch the object: the
  /// grasps the support test (SimParams::support_test) tries.
  bool SupportClear(const Mat4& tcp) const;
  /// Articulated test of one candidate (TCP in the joint body's frame) for `target`.
  SimOutcome TestJoint(const JointTarget& target, const Mat4& tcp, mjData* data) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Tests `candidates` in `order` on params.threads threads until `max_success` succeed or the
/// order ends. Deterministic: the accepted set is the first max_success successes in order.
/// `target` null: rigid; else the joint test for that joint.
MLSPACES_API SimRun TestCandidates(const GraspScene& scene,
                                   const std::vector<GraspCandidate>& candidates,
                                   const std::vector<size_t>& order, size_t max_success,
                                   const JointTarget* target, const SimParams& params,
                                   const SimProgress& progress = {});

}  // namespace mlspaces::graspgen
