// Grasp generation, the whole job: for each object of an asset library, candidates on its
// collision geometry (or on each joint's handle), the simulated test with the robot's gripper,
// and the kept grasps written as `<out>/<uid>/<robot>/grasps.npz` and
// `joint_grasps_<joint>.npz` (key `transforms`, (N,4,4)), then grasps_index.json rebuilt by the
// same code as `mlspaces index-grasps`. `mlspaces generate-grasps` and
// `mlspaces.grasp_generation.generate_grasps` call this (docs/graspgen.md).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/json.h"
#include "mlspaces/graspgen/antipodal.h"
#include "mlspaces/graspgen/grasp_sim.h"

namespace mlspaces::graspgen {

/// What to generate. Defaults: the original runners' (1,000 grasps, float16 files).
struct MLSPACES_API GenerateOptions {
  /// An asset library: its assets_index.json, or (without one) the `<uid>/<uid>.xml` +
  /// `<uid>.json` files `index-assets` would find.
  std::filesystem::path library_dir;
  /// The grasp library written to; empty: library_dir (the tutorial's layout).
  std::filesystem::path output_dir;
  std::vector<std::string> uids;  ///< empty: every object of the library
  /// Grasp-library robot name (the folder under `<uid>/`) and the robot whose gripper is
  /// tested (RobotForGraspLibrary): "droid" is franka_droid's, "xarm7" the xArm7's.
  std::string robot = "droid";
  /// false: pickup grasps of each object; true: joint grasps of each hinge and slide joint
  /// (objects without one are skipped with that reason).
  bool joints = false;
  size_t max_grasps = 1000;  ///< per object (rigid) or per joint
  uint64_t seed = 0;
  int threads = 0;         ///< <= 0: all cores; the files do not depend on it
  bool overwrite = false;  ///< false: objects (joints) whose file exists are skipped
  bool float64 = false;    ///< false: float16 like the original's files
  bool progress = true;    ///< a bar per object on a terminal
  /// An object (joint) none of whose first `give_up_after` candidates in test order passes is
  /// given up (they cover the object, so the rest would fail alike).
  size_t give_up_after = 2000;
  /// Rigid objects with the support test on: at least this fraction of the kept grasps (at
  /// least one) clears the object's support, so a pick from a table has some; when the
  /// covering order kept fewer, candidates whose open hand clears the support are tested
  /// further and their successes replace the last kept others.
  double min_support_fraction = 0.1;
  CandidateParams candidates;
  SimParams sim;
};

/// What happened to one object (rigid) or one joint.
struct MLSPACES_API ObjectReport {
  enum class Status { kDone, kSkipped, kFailed };
  std::string uid;
  std::string joint;             ///< empty for pickup grasps
  std::filesystem::path asset;   ///< the object's MJCF
  std::filesystem::path output;  ///< the NPZ (written when kDone, existing when kSkipped)
  Status status = Status::kFailed;
  size_t candidates = 0;  ///< kept by the geometric filters
  size_t tested = 0;      ///< simulated
  size_t accepted = 0;    ///< written
  int64_t steps = 0;      ///< mj_step calls over the tested candidates
  double seconds = 0;
  /// kFailed: why ("no collision geometry", "object too big for the gripper: ...",
  /// "no candidate passed the simulation: lost during shake 61%, ..."); kSkipped: "exists".
  std::string reason;
  std::map<std::string, size_t> failures;  ///< simulation failure reasons -> count
};

/// A whole run.
struct MLSPACES_API GenerateReport {
  std::vector<ObjectReport> objects;
  std::filesystem::path index;  ///< the grasps_index.json written (empty if none)
  size_t done() const;
  size_t skipped() const;
  size_t failed() const;
};

/// The robot a grasp-library robot folder name stands for: "droid" -> franka_droid, else a
/// robot of that name on robots::RobotSearchPath(). @throws UsageError for an unknown name.
MLSPACES_API std::string RobotForGraspLibrary(const std::string& robot);

/// Whether `generate-grasps --robot` can use a robot (`mlspaces inspect-robot`'s last section).
struct MLSPACES_API GraspReadiness {
  bool ready = false;
  /// Why not: GripperProxyOf's one line (the robot.yaml, the field, the problem); "" if ready.
  std::string problem;
  GripperProxy gripper;  ///< the open hand, when ready
  /// The robot is on robots::RobotSearchPath() under its name, so `--robot NAME` finds it.
  bool on_search_path = false;
};

/// GripperProxyOf(`robot`) with its error caught: a robot whose hand gives no gripper proxy
/// is `problem`, not a throw (the robot may still serve datagen with grasps made elsewhere).
MLSPACES_API GraspReadiness CheckGraspGeneration(const robots::RobotSpec& robot);
/// The same for robots::LoadRobotSpec(name_or_path), whose error is `problem` too.
MLSPACES_API GraspReadiness CheckGraspGeneration(std::string_view name_or_path);

/// The readiness as JSON: {"ready", "problem"?, "gripper_boxes", "finger_offset",
/// "ray_levels": [z0, z1], "on_search_path"}.
MLSPACES_API Json ToJson(const GraspReadiness& readiness);

/// One line: "grasp generation: ready (...): mlspaces generate-grasps --robot NAME ..." or
/// "grasp generation: not possible: <problem>"; ends with a newline.
MLSPACES_API std::string FormatGraspReadiness(const GraspReadiness& readiness,
                                              const std::string& robot_name);

/// Runs the job. Per-object problems (bad mesh, no collision geometry, nothing accepted) are
/// reported in the ObjectReport and the run goes on; `on_object` (optional) is called after
/// each object or joint, on the calling thread. Files are written atomically, so an
/// interrupted run resumes where it stopped. @throws Error for a missing library, an unknown
/// `uids` entry, or an index that cannot be written; UsageError for bad options.
MLSPACES_API GenerateReport GenerateGrasps(
    const GenerateOptions& options, const std::function<void(const ObjectReport&)>& on_object = {});

/// One line for an object report: "mug_a: 1000 grasps (1,291 tested of 13,420 candidates,
/// 2,310 steps/grasp) in 31.2 s" or "box_l: failed: <reason>".
MLSPACES_API std::string ObjectReportLine(const ObjectReport& report);

}  // namespace mlspaces::graspgen
