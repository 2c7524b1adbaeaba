// Damped-least-squares inverse kinematics of one site over a set of joints of an mjModel
// (the pick planner's IK, spec 8.4).
//
// The solver works on its own scratch mjData (never the episode's): SyncState copies the
// rest of the state (mocap base pose, other joints) from an episode's data, and each Solve
// then only moves the listed joints. Each iteration: mj_kinematics + mj_comPos, error
// e = [p_target - p; R log(R^T R_target)] (world frame, m / rad), stop when |e| < tolerance;
// J = [jacp; jacr] of the site over the listed dofs (mj_jacSite);
// dq = J^T (J J^T + lambda^2 I)^-1 e + (I - J^+ J) k (q_rest - q), the step capped at
// max_step; q += dq and clamped to the joint ranges. Joints at a limit whose step points
// outward are locked for that iteration (active set); a step that does not lower |e| is
// rejected and lambda raised (Levenberg-Marquardt), so the error decreases monotonically and
// a local minimum is detected (lambda > 1e3) instead of burning the iteration cap.
// Deterministic: the same inputs give the same bits (restarts draw from a fixed-seed
// generator).
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::robots {

struct MLSPACES_API IkOptions {
  int max_iterations = 1000;  ///< per attempt (spec 8.4: 1000)
  double tolerance = 1e-4;    ///< stop when |[e_pos; e_rot]| < tolerance (spec 8.4: 1e-4)
  /// Minimum lambda (Levenberg-Marquardt: x4 after a step that does not lower |e|, /2 after
  /// one that does); 1e-12 is essentially undamped.
  double damping = 1e-3;
  double max_step = 0.3;  ///< cap on max |dq_i| per iteration (rad or m)
  /// Null-space gain toward `rest` (e.g. the home pose); 0 (default) disables the secondary
  /// task. A posture term costs reach from far seeds (75% vs 84% of random poses from home
  /// at 0.05, see ik_test), so use it for tracking only.
  double nullspace_gain = 0.0;
  /// Extra attempts from random configurations (uniform within limits, fixed-seed RNG,
  /// re-seeded per Solve) when the seeded attempt fails: 84% -> 99.7% of random reachable
  /// poses from home with 8. They only cost time on failure. Set 0 for per-step tracking (one
  /// attempt from the measured state), where a restart could jump to another IK branch.
  int restarts = 8;
  uint64_t restart_seed = 0x5eed;
};

struct MLSPACES_API IkResult {
  bool success = false;
  std::vector<double> q;  ///< the final joint values (listed-joint order), within limits
  double pos_error = 0;   ///< |p_target - p| (m) at q
  double rot_error = 0;   ///< rotation angle between target and site (rad) at q
  int iterations = 0;     ///< total over all attempts
  int attempts = 0;       ///< 1 + restarts used
};

/// Damped minimum-norm least squares for a 6 x n Jacobian `jac` (row-major):
/// x = J^T (J J^T + lambda^2 I)^-1 b. @throws std::invalid_argument when jac.size() != 6 n.
MLSPACES_API std::vector<double> DampedLeastSquares(std::span<const double> jac, size_t n,
                                                    const std::array<double, 6>& b, double lambda);

class MLSPACES_API IkSolver {
 public:
  // ===========================================================================================
  // Construction

  /// `m` must outlive the solver. `joints` are hinge or slide joints (one dof each); limited
  /// joints are clamped to their range, unlimited ones are not. `rest` (empty: the range
  /// midpoints, or 0 for unlimited joints) is the null-space target.
  /// @throws std::invalid_argument for an unknown site/joint, a ball/free joint, or a rest of
  /// the wrong size.
  IkSolver(const mjModel* m, std::string_view site, std::span<const std::string> joints,
           std::span<const double> rest = {}, IkOptions options = {});

  // ===========================================================================================
  // Solving

  /// Copies qpos and the mocap poses of `d` (same model) into the scratch data; `d` is read
  /// during the call only.
  void SyncState(const mjData* d);

  /// Solves for the site's world pose `target` from `seed` (listed-joint order; clamped to
  /// the limits first). @throws std::invalid_argument for a seed of the wrong size.
  IkResult Solve(const Mat4& target, std::span<const double> seed);

  /// World pose of the site at joint values q (other state as last synced).
  Mat4 Forward(std::span<const double> q);

  // ===========================================================================================
  // Access (references valid while the solver lives)

  size_t num_joints() const { return qpos_adr_.size(); }
  const std::vector<double>& lower() const { return lower_; }
  const std::vector<double>& upper() const { return upper_; }
  const std::vector<bool>& limited() const { return limited_; }
  const IkOptions& options() const { return options_; }
  IkOptions& options() { return options_; }

 private:
  // One attempt from q (modified in place). Returns success.
  bool Iterate(const Mat4& target, std::vector<double>& q, int& iterations);
  // The damped least-squares step (with null-space motion) for the current Jacobian.
  void Step(const std::vector<double>& jac, const double e[6], const std::vector<double>& q,
            const std::vector<bool>& locked, double lambda, std::vector<double>& dq,
            std::vector<double>& z) const;
  void SetJoints(std::span<const double> q);
  void Error(const Mat4& target, double e[6]) const;

  const mjModel* m_;
  sim::DataPtr d_;
  int site_;
  IkOptions options_;
  std::vector<int> qpos_adr_, dof_adr_;
  std::vector<double> lower_, upper_, rest_;
  std::vector<bool> limited_;
  std::vector<double> jacp_, jacr_;  // 3 x nv each
};

}  // namespace mlspaces::robots
