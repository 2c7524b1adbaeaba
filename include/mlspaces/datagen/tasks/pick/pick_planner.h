// The pick planner policy (spec 8): plan a grasp from the object's grasp library, then drive the
// arm through the pick phases (PolicyPhase) with per-step IK, retrying from the current state
// when a phase fails. Differences from the reference implementation: docs/datagen.md.
//
// Plan (at the start of an episode and on every retry):
//   1. candidates = object pose x library grasps, plus their 180-degree flips about the TCP z;
//   2. rank by GraspCost, keep policy.grasp_collision_max_grasps, drop those where
//      the open gripper would touch anything (GraspCollisionChecker, no proxy bodies in the
//      simulated model), IK-check the rest in cost order from the measured arm state and take
//      the first feasible one;
//   3. pregrasp = grasp + pregrasp_z_offset along world z, lift = grasp + postgrasp_z_offset;
//      each of the three must have an IK solution;
//   4. phases: gripper open (instant) -> travel to the lift pose above the grasp (joint space,
//      speed_fast along the TCP, at most 1 rad/s per joint; on a retry, with the TCP below the
//      lift height: straight up to it, then across in Cartesian space) -> down to the pregrasp
//      (speed_fast) -> down to the grasp (speed_slow) -> settle -> close
//      (gripper_close_duration) -> lift (speed_slow, holding) -> settle.
//      The joint-space travel avoids one Cartesian line to the pregrasp, along which a yawed
//      object can need a wrist turn past the joint limits mid-way that per-step IK cannot
//      follow.
// Act (once per policy step, on the simulation clock d->time):
//   - a Cartesian segment's target at elapsed time t is the straight-line/slerp interpolation
//     between its end poses (a joint segment's: the joint-space interpolation), evaluated one
//     policy step ahead (where the arm should be when the step ends, not where it was when the
//     step started, which would lag a step behind);
//     the arm command is an IK solution of it seeded with the previous command (continuous);
//   - a move fails when the TCP is more than tcp_pos_err_threshold / tcp_rot_err_threshold
//     from the target of the current time (something blocks the arm), when the gripper closes
//     on nothing while holding (gap < gripper_empty_threshold), or after
//     max_sequential_ik_failures IK failures in a row (phases are timed on the simulation
//     clock and always end, so there is no phase timeout);
//   - a failure replans from the current state (after re-opening the gripper), at most
//     max_retries times; then the planner gives up (done, with the failure's reason).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/json.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/grasp_selection.h"
#include "mlspaces/robots/ik.h"
#include "mlspaces/robots/robot_view.h"

namespace mlspaces::datagen {

/// The policy phase ids (obs/extra/policy_phase; docs/dataset.md).
enum class PolicyPhase : int64_t {
  kUnknown = 0,
  kGripperOpen = 1,
  kPregrasp = 2,
  kGrasp = 3,
  kGripperClose = 4,
  kLift = 5,
  kPreplace = 6,
  kPlace = 7,
  kRetreat = 8,
  kGoHome = 9,
};

/// The phase map {"unknown": 0, "gripper-open": 1, ..., "go_home": 9}.
MLSPACES_API Json PolicyPhaseMap();

/// Why planning or execution failed.
enum class PlanFailure {
  kNone,
  kNoGrasp,     ///< no candidate survived the collision and IK checks (or no grasps at all)
  kIkFail,      ///< pregrasp, grasp or lift has no IK solution; or IK failed step after step
  kCollision,   ///< the TCP fell too far behind its target: the arm is blocked
  kEmptyGrasp,  ///< the gripper closed on nothing, or let go while lifting
};
/// The failure's name: a static string, never null.
MLSPACES_API const char* PlanFailureName(PlanFailure failure);

/// One policy step's command.
struct MLSPACES_API PlannerAction {
  std::vector<double> arm;  ///< absolute joint targets
  double gripper = 0;       ///< gripper ctrl
  bool done = false;        ///< the plan finished (or was given up): the episode ends
};

/// What the planner did, for the journal.
struct MLSPACES_API PlannerStats {
  size_t num_candidates = 0;
  size_t num_collision_free = 0;
  size_t num_ik_checked = 0;
  int64_t ik_calls = 0;
  int64_t ik_failures = 0;
  double plan_seconds = 0;
};

class MLSPACES_API PickPlanner {
 public:
  // ===========================================================================================
  // Construction

  /// Builds the IK solver and the grasp collision probe for `env`'s model. `env` and `robot`
  /// are kept by pointer: both (and the model) must outlive the planner. One planner serves
  /// every episode of the env. `policy_dt` is the policy step in seconds (the experiment's
  /// policy_dt_ms / 1000).
  PickPlanner(const Env& env, const robots::RobotView& robot, const PolicyConfig& config,
              double policy_dt);
  virtual ~PickPlanner();
  PickPlanner(const PickPlanner&) = delete;
  PickPlanner& operator=(const PickPlanner&) = delete;

  // ===========================================================================================
  // Per episode

  /// Starts an episode: `object_body` is the pickup object's body id and `grasps` its library
  /// grasps in the body frame. Plans from the state in `d` (forward must have run).
  /// @returns kNone, or why no plan exists (message() says more).
  PlanFailure Reset(const mjData* d, int object_body, std::vector<Mat4> grasps);

  /// The command for the policy step that starts at d->time.
  PlannerAction Act(const mjData* d);

  // ===========================================================================================
  // State (references valid while the planner lives; they change with Reset and Act)

  /// The phase of the last Act (kUnknown before the first).
  PolicyPhase phase() const { return phase_; }
  /// Retries so far in this episode.
  int retries() const { return retries_; }
  /// The planned grasp (world TCP pose), identity before a plan exists.
  const Mat4& grasp_pose() const { return grasp_; }
  /// True after the planner gave up (failure() says why).
  bool gave_up() const { return gave_up_; }
  /// The last failure (kNone when nothing failed yet).
  PlanFailure failure() const { return failure_; }
  const std::string& message() const { return message_; }
  const PlannerStats& stats() const { return stats_; }
  /// The index (into library grasps, flips counted after them) of the planned grasp.
  std::optional<size_t> grasp_index() const { return grasp_index_; }

 protected:
  // For planners of other tasks (tasks/open_close/planner.h): they replace Plan and reuse
  // Act's execution of primitives_.
  struct Segment {
    Mat4 start, end;
    double duration = 0;
    PolicyPhase phase = PolicyPhase::kUnknown;
    /// Joint-space travel (linear in the joints) when set; else a Cartesian line + slerp.
    std::vector<double> q_start, q_end;
  };
  struct Primitive {
    bool move = false;
    PolicyPhase phase = PolicyPhase::kUnknown;  // gripper primitives
    double gripper = 0;                         // gripper primitives
    double duration = 0;                        // gripper primitives
    std::vector<Segment> segments;              // moves
    double settle = 0;                          // moves
    bool holding = false;                       // moves
  };

  /// A Cartesian segment timed by `timing`.
  static Segment Line(const Mat4& start, const Mat4& end, const SegmentTiming& timing,
                      PolicyPhase phase);
  /// Joint-space travel from q_start (at pose start) to q_end (at end): Line's duration, or
  /// longer so no joint moves faster than 1 rad/s.
  static Segment JointTravel(const Mat4& start, const Mat4& end, std::vector<double> q_start,
                             std::vector<double> q_end, const SegmentTiming& timing,
                             PolicyPhase phase);
  /// A gripper primitive: `ctrl` held for `duration` s.
  static Primitive Gripper(PolicyPhase phase, double ctrl, double duration);
  /// Fills primitives_ (and grasp_, grasp_index_, stats_) from the state in `d`.
  virtual PlanFailure Plan(const mjData* d);
  void Fail(PlanFailure failure, std::string message);
  bool SolveIk(const Mat4& target, std::vector<double>& q, bool allow_restarts);

  const Env* env_;
  const robots::RobotView* robot_;
  PolicyConfig config_;
  double dt_policy_;
  std::unique_ptr<robots::IkSolver> ik_;
  std::unique_ptr<GraspCollisionChecker> probe_;

  int object_body_ = -1;
  std::vector<Mat4> grasps_local_;
  std::vector<Primitive> primitives_;
  size_t current_ = 0;
  std::optional<double> started_at_;
  std::vector<double> command_;  // last arm command
  double gripper_command_ = 0;
  int ik_fail_streak_ = 0;
  int retries_ = 0;
  bool gave_up_ = false;
  bool pending_retry_ = false;
  PlanFailure failure_ = PlanFailure::kNone;
  std::string message_;
  PolicyPhase phase_ = PolicyPhase::kUnknown;
  Mat4 grasp_;
  std::optional<size_t> grasp_index_;
  PlannerStats stats_;
};

}  // namespace mlspaces::datagen
