#include "mlspaces/sim/describe.h"

#include "mlspaces/sim/asset_facts.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::sim {

const char* JointTypeName(int t) {
  switch (t) {
    case mjJNT_FREE:
      return "free";
    case mjJNT_BALL:
      return "ball";
    case mjJNT_SLIDE:
      return "slide";
    default:
      return "hinge";
  }
}

namespace {

const char* TrnType(int t) {
  switch (t) {
    case mjTRN_JOINT:
      return "joint";
    case mjTRN_JOINTINPARENT:
      return "jointinparent";
    case mjTRN_TENDON:
      return "tendon";
    case mjTRN_SITE:
      return "site";
    case mjTRN_BODY:
      return "body";
    default:
      return "slidercrank";
  }
}

template <size_t N>
Json Vec(const std::array<double, N>& v) {
  Json a = Json::array();
  for (double x : v) a.push_back(x);
  return a;
}

template <size_t N>
Json OptionalVec(const std::optional<std::array<double, N>>& v) {
  return v ? Vec(*v) : Json(nullptr);
}

std::array<double, 2> Pair(const mjtNum* v) { return {v[0], v[1]}; }

}  // namespace

ModelDescription DescribeModel(const MjcfComposer& composer, const std::string& file) {
  ModelPtr model = composer.Compile();
  const mjModel* m = model.get();
  DataPtr data = MakeData(m);
  const mjData* d = data.get();
  mj_kinematics(m, data.get());
  ModelDescription out;
  out.file = file;
  out.ngeom = m->ngeom;
  for (int b = 0; b < m->nbody; ++b) {
    BodyDescription body;
    body.name = MjName(m, mjOBJ_BODY, b);
    body.parent = MjName(m, mjOBJ_BODY, m->body_parentid[b]);
    body.pose = BodyPose(d, b);
    body.mass = m->body_mass[b];
    body.ngeom = m->body_geomnum[b];
    Vec3 lo, hi;
    if (BodyGeomBox(m, d, b, &lo, &hi)) body.box = std::array<Vec3, 2>{lo, hi};
    out.bodies.push_back(std::move(body));
  }
  for (int j = 0; j < m->njnt; ++j) {
    JointDescription joint{MjName(m, mjOBJ_JOINT, j), JointTypeName(m->jnt_type[j]),
                           MjName(m, mjOBJ_BODY, m->jnt_bodyid[j]), std::nullopt};
    if (m->jnt_limited[j]) joint.range = Pair(m->jnt_range + 2 * j);
    out.joints.push_back(std::move(joint));
  }
  for (int a = 0; a < m->nu; ++a) {
    const int trn = m->actuator_trntype[a];
    const mjtObj obj = trn == mjTRN_TENDON ? mjOBJ_TENDON
                       : trn == mjTRN_SITE ? mjOBJ_SITE
                       : trn == mjTRN_BODY ? mjOBJ_BODY
                                           : mjOBJ_JOINT;
    ActuatorDescription actuator{MjName(m, mjOBJ_ACTUATOR, a), TrnType(trn),
                                 MjName(m, obj, m->actuator_trnid[2 * a]), std::nullopt};
    if (m->actuator_ctrllimited[a]) actuator.ctrlrange = Pair(m->actuator_ctrlrange + 2 * a);
    out.actuators.push_back(std::move(actuator));
  }
  for (int c = 0; c < m->ncam; ++c) {
    out.cameras.push_back({MjName(m, mjOBJ_CAMERA, c),
                           MjName(m, mjOBJ_BODY, m->cam_bodyid[c]),
                           {d->cam_xpos[3 * c], d->cam_xpos[3 * c + 1], d->cam_xpos[3 * c + 2]},
                           m->cam_fovy[c]});
  }
  out.warnings = composer.warnings();
  return out;
}

Json ToJson(const ModelDescription& description) {
  Json out;
  out["file"] = description.file;
  Json bodies = Json::array();
  for (const BodyDescription& b : description.bodies) {
    Json jb;
    jb["name"] = b.name;
    jb["parent"] = b.parent;
    jb["pos"] = Vec(b.pose.pos);
    jb["quat"] = Vec(b.pose.quat);
    jb["mass"] = b.mass;
    jb["ngeom"] = b.ngeom;
    if (b.box) {
      jb["aabb"] = {{"min", Vec((*b.box)[0])}, {"max", Vec((*b.box)[1])}};
    } else {
      jb["aabb"] = nullptr;
    }
    bodies.push_back(jb);
  }
  out["bodies"] = bodies;
  Json joints = Json::array();
  for (const JointDescription& j : description.joints) {
    Json jj = {{"name", j.name}, {"type", j.type}, {"body", j.body}};
    jj["range"] = OptionalVec(j.range);
    joints.push_back(jj);
  }
  out["joints"] = joints;
  Json actuators = Json::array();
  for (const ActuatorDescription& a : description.actuators) {
    Json ja = {{"name", a.name}, {"transmission", a.transmission}, {"target", a.target}};
    ja["ctrlrange"] = OptionalVec(a.ctrlrange);
    actuators.push_back(ja);
  }
  out["actuators"] = actuators;
  Json cameras = Json::array();
  for (const CameraDescription& c : description.cameras) {
    cameras.push_back({{"name", c.name}, {"body", c.body}, {"pos", Vec(c.pos)}, {"fovy", c.fovy}});
  }
  out["cameras"] = cameras;
  Json warnings = Json::array();
  for (const Diagnostic& w : description.warnings) warnings.push_back(MujocoWarningLine(w));
  out["warnings"] = warnings;
  return out;
}

}  // namespace mlspaces::sim
