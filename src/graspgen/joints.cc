// Joints of articulated assets, their handle geometry and candidates on the handle
// (include/mlspaces/graspgen/joints.h).
#include "mlspaces/graspgen/joints.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::graspgen {
namespace {

constexpr double kMaxSlideTravel = 0.4;  // m, unlimited slide

std::string BodyName(const mjModel* m, int b) {
  const char* name = mj_id2name(m, mjOBJ_BODY, b);
  return name != nullptr ? std::string(name) : "#" + std::to_string(b);
}

// Bodies between geom body `b` and `top` (0 = top itself), or -1 when `b` is not below `top`.
int DepthBelow(const mjModel* m, int b, int top) {
  int depth = 0;
  while (b != top && b != 0) {
    b = m->body_parentid[b];
    ++depth;
  }
  return b == top ? depth : -1;
}

}  // namespace

std::vector<JointTarget> FindJointTargets(const std::filesystem::path& asset_file) {
  const std::string source = asset_file.string();
  const sim::ModelPtr model = sim::ComposeAndCompile(asset_file);
  const mjModel* m = model.get();
  int root = -1;
  for (int b = 1; b < m->nbody && root < 0; ++b) {
    if (m->body_parentid[b] == 0) root = b;
  }
  if (root < 0) throw Error("the asset has no body", source);
  const std::vector<int> object_geoms = sim::CollisionGeoms(m, root);

  std::vector<JointTarget> out;
  for (int j = 0; j < m->njnt; ++j) {
    const int type = m->jnt_type[j];
    if (type != mjJNT_HINGE && type != mjJNT_SLIDE) continue;
    const int body = m->jnt_bodyid[j];
    if (DepthBelow(m, body, root) < 0) continue;
    const char* name = mj_id2name(m, mjOBJ_JOINT, j);
    if (name == nullptr || *name == '\0') {
      throw Error("joint #" + std::to_string(j) + " of body " + BodyName(m, body) +
                      " has no name (joint grasps are stored by joint name)",
                  source);
    }
    JointTarget t;
    t.joint = name;
    t.body = BodyName(m, body);
    t.hinge = type == mjJNT_HINGE;
    t.axis = {m->jnt_axis[3 * j], m->jnt_axis[3 * j + 1], m->jnt_axis[3 * j + 2]};
    t.anchor = {m->jnt_pos[3 * j], m->jnt_pos[3 * j + 1], m->jnt_pos[3 * j + 2]};
    t.limited = m->jnt_limited[j] != 0;
    if (t.limited) t.range = {m->jnt_range[2 * j], m->jnt_range[2 * j + 1]};

    // Handle: the collision geoms of the subtree at the greatest depth below the joint body.
    const std::vector<int> subtree = sim::CollisionGeoms(m, body);
    int max_depth = -1;
    for (int g : subtree) max_depth = std::max(max_depth, DepthBelow(m, m->geom_bodyid[g], body));
    std::vector<int> handle;
    for (int g : subtree) {
      if (DepthBelow(m, m->geom_bodyid[g], body) != max_depth) continue;
      handle.push_back(g);
      const char* geom = mj_id2name(m, mjOBJ_GEOM, g);
      t.handle_geoms.push_back(geom != nullptr ? std::string(geom) : "#" + std::to_string(g));
    }
    if (!handle.empty()) t.handle = GeomsMesh(m, handle, body, source);
    if (!object_geoms.empty()) t.object = GeomsMesh(m, object_geoms, body, source);

    const double q0 = m->qpos0[m->jnt_qposadr[j]];
    if (t.limited) {
      const double d0 = t.range[0] - q0, d1 = t.range[1] - q0;
      t.travel = std::abs(d1) >= std::abs(d0) ? d1 : d0;
    } else if (t.hinge) {
      t.travel = std::numbers::pi / 2;
    } else if (!subtree.empty()) {  // the moving part's extent along the axis
      const TriMesh part = GeomsMesh(m, subtree, body, source);
      double lo = 1e300, hi = -1e300;
      for (const Vec3& v : part.vertices) {
        const double s = v[0] * t.axis[0] + v[1] * t.axis[1] + v[2] * t.axis[2];
        lo = std::min(lo, s);
        hi = std::max(hi, s);
      }
      t.travel = std::min(kMaxSlideTravel, hi - lo);
    }
    out.push_back(std::move(t));
  }
  if (out.empty()) {
    throw Error("no hinge or slide joint in body " + BodyName(m, root) + " or below", source);
  }
  return out;
}

CandidateSet GenerateJointCandidates(const JointTarget& target, const GripperProxy& gripper,
                                     const CandidateParams& params, uint64_t seed) {
  if (target.handle.faces.empty()) {
    throw Error("joint " + target.joint + " has no handle geometry (no collision geom in body " +
                target.body + " or below)");
  }
  const MeshBvh handle(target.handle);
  if (target.object.faces.empty()) return GenerateCandidates(handle, gripper, params, seed);
  const MeshBvh object(target.object);
  return GenerateCandidates(handle, gripper, params, seed, &object);
}

}  // namespace mlspaces::graspgen
