// Grasp selection for the pick planner (spec 9): a ranking cost over world-frame candidates,
// and a collision test of the open gripper at each candidate that adds no proxy bodies to the
// simulated model. Differences from the reference implementation: docs/datagen.md.
//
// Collision test design (GraspCollisionChecker). A separate *probe model* is compiled once per
// scene: a copy of the composed scene (robot and objects included) with one free-floating probe
// body attached last to the worldbody (MjcfComposer::AttachString), compiled. The probe body's
// frame is the TCP frame; its geoms are either
//  - kGripperGeoms (default): the collision geoms of the robot's own gripper subtree, read from
//    the compiled sim model at the model's reference pose qpos0 (franka_droid: drivers at 0 =
//    fully open, 85 mm) and expressed in the TCP site frame (mesh geoms become their bounding
//    box), or
//  - kMolmoSpacesProxy: three 5 mm cylinders (a 0.08 m bar 0.04 m behind the TCP and two
//    0.05 m fingers at y = +-0.04, z in [-0.04, 0.01]).
// Appending one body with a free joint keeps the sim's layout as a prefix of the probe model's:
// qpos[0, nq_sim), mocap ids and geom ids [0, ngeom_sim) are the sim's, so SyncState copies the
// episode's qpos and mocap poses verbatim and a contact names the sim geom that was hit. (A
// mocap probe would not do: MuJoCo never collides two bodies welded to the world, so it would
// miss the floor and every static geom.) In the probe model every non-probe geom gets
// conaffinity 0 and explicit <pair>s are dropped, so mj_collision only generates probe
// contacts: probe geoms have contype 0 / conaffinity 15, so they
// hit every geom with a contype bit in 0-3 (scene, objects and, unless disabled, the robot).
// A candidate costs one mj_kinematics + mj_collision on the probe model's own mjData; the
// episode's model and data are never touched.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {

/// Weights of the grasp ranking cost (spec 9.1).
struct MLSPACES_API GraspCostWeights {
  double tcp_distance = 1.0;     ///< |p(T^-1 G)| (m)
  double tcp_angle_deg = 0.01;   ///< angle(T^-1 G) in degrees
  double approach_z = 2.0;       ///< G[2,2] (z of the approach axis; -1 = top-down)
  double approach_z_sq = 0.0;    ///< G[2,2]^2
  double object_distance = 8.0;  ///< |p(O^-1 G)| (m)
};

/// cost = w1 |p(T^-1 G)| + w2 angle_deg(T^-1 G) + w3 G[2,2] + w4 G[2,2]^2 + w5 |p(O^-1 G)|,
/// with G the world-frame grasp, T the current TCP pose and O the object pose.
double GraspCost(const Mat4& grasp, const Mat4& tcp, const Mat4& object,
                 const GraspCostWeights& weights = {});

/// Indices of the `keep` cheapest grasps, cheapest first; ties keep input order (a stable
/// argsort).
std::vector<size_t> RankGrasps(std::span<const Mat4> grasps, const Mat4& tcp, const Mat4& object,
                               size_t keep = 512, const GraspCostWeights& weights = {});

struct MLSPACES_API GraspSelectionOptions {
  GraspCostWeights weights;
  size_t max_ranked = 512;      ///< candidates kept after ranking (spec 9.1)
  size_t max_ik_checked = 256;  ///< collision-free candidates IK-checked, in cost order
};

struct MLSPACES_API GraspSelection {
  std::optional<size_t> index;  ///< the chosen grasp (index into the candidates), if any
  std::vector<size_t> ranked;   ///< the ranked candidates, cheapest first
  size_t num_collision_free = 0;
  size_t num_ik_checked = 0;
};

/// Spec 9.1: rank, keep `max_ranked`, drop those `collision_free` rejects, then IK-check the
/// survivors in cost order (the first `max_ik_checked`) and take the first feasible one.
/// Either predicate may be empty (= always true).
GraspSelection SelectGrasp(std::span<const Mat4> grasps, const Mat4& tcp, const Mat4& object,
                           const std::function<bool(const Mat4&)>& collision_free,
                           const std::function<bool(const Mat4&)>& ik_feasible,
                           const GraspSelectionOptions& options = {});

enum class ProbeShape { kGripperGeoms, kMolmoSpacesProxy };

struct MLSPACES_API GraspProbeOptions {
  ProbeShape shape = ProbeShape::kGripperGeoms;
  /// Root body of the gripper subtree whose geoms form the probe (kGripperGeoms).
  std::string gripper_body = "robot_0/gripper/base";
  /// The TCP site: the probe frame.
  std::string tcp_site = "robot_0/gripper/grasp_site";
  /// Whether the probe may hit the robot's own geoms.
  bool collide_with_robot = true;
  /// Names starting with this are robot geoms (for collide_with_robot = false).
  std::string robot_prefix = "robot_0/";
  /// Extra clearance (m): geoms closer than this count as colliding (probe geom margin).
  double clearance = 0.0;
};

/// One contact of the probe at a candidate.
struct MLSPACES_API ProbeContact {
  int sim_geom = -1;    ///< the geom hit, a geom id of the sim model
  int probe_geom = -1;  ///< index of the probe geom (0-based, in probe order)
  double dist = 0;      ///< signed distance (negative = penetration)
};

/// Owns the probe model and its mjData; the sim model and data passed in are read during the
/// call only.
class MLSPACES_API GraspCollisionChecker {
 public:
  // ===========================================================================================
  // Construction

  /// Compiles the probe model from the composed scene `scene` (robot and objects inserted),
  /// whose compilation is `sim`. `sim` is read here only. @throws Error / std::invalid_argument
  /// for a missing gripper body or TCP site, or when the probe model's layout does not extend
  /// the sim's.
  GraspCollisionChecker(const sim::MjcfComposer& scene, const mjModel* sim,
                        const GraspProbeOptions& options = {});

  // ===========================================================================================
  // Per episode

  /// Copies qpos and mocap poses from the episode's data (of `sim`) into the probe data.
  void SyncState(const mjData* sim_data);

  // ===========================================================================================
  // Per candidate

  /// True when the open gripper placed with its TCP at `grasp` (world) touches anything.
  bool Collides(const Mat4& grasp);
  /// The contacts of the probe at `grasp` (empty = collision-free).
  std::vector<ProbeContact> Contacts(const Mat4& grasp);
  /// Per candidate: true = collision-free.
  std::vector<bool> NonCollidingMask(std::span<const Mat4> grasps);

  // ===========================================================================================
  // Access

  /// The probe model: never null, owned by the checker, valid while it lives.
  const mjModel* probe_model() const { return model_.get(); }
  int num_probe_geoms() const { return num_probe_geoms_; }

 private:
  int PlaceAndCollide(const Mat4& grasp);  // returns number of probe contacts

  sim::ModelPtr model_;
  sim::DataPtr data_;
  int nq_sim_ = 0;
  int nmocap_ = 0;
  int first_probe_geom_ = 0;
  int num_probe_geoms_ = 0;
  int probe_qpos_ = 0;
};

}  // namespace mlspaces::datagen
