#include "mlspaces/datagen/grasp_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
constexpr const char* kProbeName = "__mlspaces_grasp_probe__";

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::string Vec(std::initializer_list<double> vs) {
  std::string s;
  for (double v : vs) {
    if (!s.empty()) s += ' ';
    s += Num(v);
  }
  return s;
}

// The probe geoms (MJCF <geom> elements in the TCP frame) for the gripper subtree of `sim`.
std::vector<std::string> GripperProbeGeoms(const mjModel* sim, const GraspProbeOptions& opt,
                                           const std::string& common) {
  const int root = mj_name2id(sim, mjOBJ_BODY, opt.gripper_body.c_str());
  if (root < 0) {
    throw Error("grasp collision probe: the model has no gripper body '" + opt.gripper_body + "'");
  }
  const int site = mj_name2id(sim, mjOBJ_SITE, opt.tcp_site.c_str());
  if (site < 0) {
    throw Error("grasp collision probe: the model has no TCP site '" + opt.tcp_site + "'");
  }
  sim::DataPtr d = sim::MakeData(sim);  // qpos = qpos0: the gripper's reference (open) pose
  mj_kinematics(sim, d.get());
  const Mat4 tcp_inv = InverseRigid(sim::SiteMat4(d.get(), site));
  std::vector<std::string> geoms;
  for (int g : sim::CollisionGeoms(sim, root)) {  // visual geoms left out
    Mat4 rel = tcp_inv * sim::GeomMat4(d.get(), g);
    const mjtNum* size = sim->geom_size + 3 * g;
    std::string type, size_attr;
    switch (sim->geom_type[g]) {
      case mjGEOM_SPHERE:
        type = "sphere", size_attr = Vec({size[0]});
        break;
      case mjGEOM_CAPSULE:
        type = "capsule", size_attr = Vec({size[0], size[1]});
        break;
      case mjGEOM_CYLINDER:
        type = "cylinder", size_attr = Vec({size[0], size[1]});
        break;
      case mjGEOM_ELLIPSOID:
        type = "ellipsoid", size_attr = Vec({size[0], size[1], size[2]});
        break;
      case mjGEOM_BOX:
        type = "box", size_attr = Vec({size[0], size[1], size[2]});
        break;
      case mjGEOM_MESH: {  // its bounding box in the geom frame
        const int mesh = sim->geom_dataid[g];
        const float* v = sim->mesh_vert + 3 * sim->mesh_vertadr[mesh];
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int i = 0; i < sim->mesh_vertnum[mesh]; ++i) {
          for (int c = 0; c < 3; ++c) {
            lo[c] = std::min(lo[c], static_cast<double>(v[3 * i + c]));
            hi[c] = std::max(hi[c], static_cast<double>(v[3 * i + c]));
          }
        }
        Mat4 offset;
        for (int c = 0; c < 3; ++c) offset(c, 3) = 0.5 * (lo[c] + hi[c]);
        rel = rel * offset;
        type = "box";
        size_attr = Vec({0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1]), 0.5 * (hi[2] - lo[2])});
        break;
      }
      default:
        continue;  // planes / height fields do not belong to a gripper
    }
    const Quat q = QuatFromMat4(rel);
    geoms.push_back("<geom type=\"" + type + "\" size=\"" + size_attr + "\" pos=\"" +
                    Vec({rel(0, 3), rel(1, 3), rel(2, 3)}) + "\" quat=\"" +
                    Vec({q[0], q[1], q[2], q[3]}) + "\"" + common + "/>");
  }
  if (geoms.empty()) {
    throw Error("grasp collision probe: gripper body '" + opt.gripper_body +
                "' has no collision geoms");
  }
  return geoms;
}

std::vector<std::string> ProxyProbeGeoms(const std::string& common) {
  // The original's proxy: three 5 mm cylinders in the TCP frame.
  return {
      "<geom type=\"cylinder\" size=\"0.005\" fromto=\"0 -0.04 -0.04 0 0.04 -0.04\"" + common +
          "/>",
      "<geom type=\"cylinder\" size=\"0.005\" fromto=\"0 -0.04 -0.04 0 -0.04 0.01\"" + common +
          "/>",
      "<geom type=\"cylinder\" size=\"0.005\" fromto=\"0 0.04 -0.04 0 0.04 0.01\"" + common + "/>",
  };
}

}  // namespace

double GraspCost(const Mat4& grasp, const Mat4& tcp, const Mat4& object,
                 const GraspCostWeights& w) {
  const Mat4 rel_tcp = InverseRigid(tcp) * grasp;
  const Mat4 rel_obj = InverseRigid(object) * grasp;
  const double d_tcp = std::hypot(rel_tcp(0, 3), rel_tcp(1, 3), rel_tcp(2, 3));
  const double angle_deg = RotationAngle(Mat4{}, rel_tcp) * kRadToDeg;
  const double z = grasp(2, 2);
  const double d_obj = std::hypot(rel_obj(0, 3), rel_obj(1, 3), rel_obj(2, 3));
  return w.tcp_distance * d_tcp + w.tcp_angle_deg * angle_deg + w.approach_z * z +
         w.approach_z_sq * z * z + w.object_distance * d_obj;
}

std::vector<size_t> RankGrasps(std::span<const Mat4> grasps, const Mat4& tcp, const Mat4& object,
                               size_t keep, const GraspCostWeights& weights) {
  std::vector<double> cost(grasps.size());
  for (size_t i = 0; i < grasps.size(); ++i) cost[i] = GraspCost(grasps[i], tcp, object, weights);
  std::vector<size_t> order(grasps.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return cost[a] < cost[b]; });
  if (order.size() > keep) order.resize(keep);
  return order;
}

GraspSelection SelectGrasp(std::span<const Mat4> grasps, const Mat4& tcp, const Mat4& object,
                           const std::function<bool(const Mat4&)>& collision_free,
                           const std::function<bool(const Mat4&)>& ik_feasible,
                           const GraspSelectionOptions& options) {
  GraspSelection out;
  out.ranked = RankGrasps(grasps, tcp, object, options.max_ranked, options.weights);
  std::vector<size_t> survivors;
  for (size_t i : out.ranked) {
    if (!collision_free || collision_free(grasps[i])) survivors.push_back(i);
  }
  out.num_collision_free = survivors.size();
  for (size_t k = 0; k < survivors.size() && k < options.max_ik_checked; ++k) {
    ++out.num_ik_checked;
    if (!ik_feasible || ik_feasible(grasps[survivors[k]])) {
      out.index = survivors[k];
      break;
    }
  }
  return out;
}

GraspCollisionChecker::GraspCollisionChecker(const sim::MjcfComposer& scene, const mjModel* sim,
                                             const GraspProbeOptions& options) {
  const std::string common = " contype=\"0\" conaffinity=\"15\" condim=\"3\" group=\"5\"" +
                             std::string(" margin=\"") + Num(options.clearance) +
                             "\" gap=\"0\" mass=\"0.01\"";
  const std::vector<std::string> geoms = options.shape == ProbeShape::kGripperGeoms
                                             ? GripperProbeGeoms(sim, options, common)
                                             : ProxyProbeGeoms(common);
  // Appended piece by piece: GCC 12 warns falsely on `std::string(literal) + literal`
  // (-Warray-bounds, GCC bug 105651).
  std::string body = "<body name=\"";
  body.append(kProbeName).append("\" pos=\"0 0 -10\"><freejoint name=\"");
  body.append(kProbeName).append("/joint\"/>");
  for (const std::string& g : geoms) body += g;
  body += "</body>";

  // The scene with the probe attached last (so its body, joint and geoms come after the
  // sim model's), compiled from the scene's spec.
  sim::MjcfComposer with_probe = scene;
  with_probe.AttachString(
      "<mujoco model=\"grasp_probe\"><worldbody>" + body + "</worldbody></mujoco>",
      scene.path().parent_path() / "grasp_probe.xml", "world", "", Pose{});
  model_ = with_probe.Compile();
  mjModel* m = model_.get();

  nq_sim_ = sim->nq;
  nmocap_ = sim->nmocap;
  first_probe_geom_ = sim->ngeom;
  num_probe_geoms_ = static_cast<int>(geoms.size());
  const int probe_body = mj_name2id(m, mjOBJ_BODY, kProbeName);
  const int probe_joint =
      mj_name2id(m, mjOBJ_JOINT, std::string(kProbeName).append("/joint").c_str());
  if (m->nq != sim->nq + 7 || m->nmocap != sim->nmocap || m->nbody != sim->nbody + 1 ||
      m->ngeom != sim->ngeom + num_probe_geoms_ || probe_body != sim->nbody || probe_joint < 0 ||
      m->jnt_qposadr[probe_joint] != sim->nq || m->body_geomadr[probe_body] != first_probe_geom_) {
    throw Error("grasp collision probe: the scene does not compile to the sim model's layout",
                scene.path().string());
  }
  probe_qpos_ = m->jnt_qposadr[probe_joint];

  // Only probe contacts: others see nobody; the robot optionally becomes invisible.
  for (int g = 0; g < first_probe_geom_; ++g) {
    m->geom_conaffinity[g] = 0;
    if (!options.collide_with_robot) {
      const std::string name = sim::MjName(m, mjOBJ_GEOM, g);
      const std::string body_name = sim::MjName(m, mjOBJ_BODY, m->geom_bodyid[g]);
      if (name.starts_with(options.robot_prefix) || body_name.starts_with(options.robot_prefix)) {
        m->geom_contype[g] = 0;
      }
    }
  }
  m->npair = 0;  // explicit <pair>s never involve the probe
  m->opt.disableflags &= ~mjDSBL_CONTACT;
  data_ = sim::MakeData(m);
}

void GraspCollisionChecker::SyncState(const mjData* sim_data) {
  std::copy(sim_data->qpos, sim_data->qpos + nq_sim_, data_->qpos);
  std::copy(sim_data->mocap_pos, sim_data->mocap_pos + 3 * nmocap_, data_->mocap_pos);
  std::copy(sim_data->mocap_quat, sim_data->mocap_quat + 4 * nmocap_, data_->mocap_quat);
}

int GraspCollisionChecker::PlaceAndCollide(const Mat4& grasp) {
  const Quat q = QuatFromMat4(grasp);
  mjtNum* qp = data_->qpos + probe_qpos_;
  for (int c = 0; c < 3; ++c) qp[c] = grasp(c, 3);
  for (int c = 0; c < 4; ++c) qp[3 + c] = q[c];
  mj_kinematics(model_.get(), data_.get());
  mj_collision(model_.get(), data_.get());
  int n = 0;
  for (int i = 0; i < data_->ncon; ++i) {
    const mjContact& c = data_->contact[i];
    if (c.geom1 >= first_probe_geom_ || c.geom2 >= first_probe_geom_) ++n;
  }
  return n;
}

bool GraspCollisionChecker::Collides(const Mat4& grasp) { return PlaceAndCollide(grasp) > 0; }

std::vector<ProbeContact> GraspCollisionChecker::Contacts(const Mat4& grasp) {
  PlaceAndCollide(grasp);
  std::vector<ProbeContact> out;
  for (int i = 0; i < data_->ncon; ++i) {
    const mjContact& c = data_->contact[i];
    const bool p1 = c.geom1 >= first_probe_geom_, p2 = c.geom2 >= first_probe_geom_;
    if (p1 == p2) continue;
    const int probe = p1 ? c.geom1 : c.geom2, other = p1 ? c.geom2 : c.geom1;
    out.push_back({other, probe - first_probe_geom_, c.dist});
  }
  return out;
}

std::vector<bool> GraspCollisionChecker::NonCollidingMask(std::span<const Mat4> grasps) {
  std::vector<bool> mask(grasps.size());
  for (size_t i = 0; i < grasps.size(); ++i) mask[i] = !Collides(grasps[i]);
  return mask;
}

}  // namespace mlspaces::datagen
