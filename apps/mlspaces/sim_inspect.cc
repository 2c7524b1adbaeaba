// mlspaces inspect FILE.xml [--json] [--emit-mjcf]: compose + compile any MJCF and print what
// MuJoCo made of it (bodies with world pose, mass and geom box; joints; actuators; cameras).
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/json.h"
#include "mlspaces/sim/asset_facts.h"
#include "mlspaces/sim/mjcf_composer.h"

namespace mlspaces::cli {
namespace {

struct InspectFlags {
  std::string file;
  bool json = false;
  bool emit = false;
};

const char* JointType(int t) {
  switch (t) {
    case mjJNT_FREE: return "free";
    case mjJNT_BALL: return "ball";
    case mjJNT_SLIDE: return "slide";
    default: return "hinge";
  }
}

const char* TrnType(int t) {
  switch (t) {
    case mjTRN_JOINT: return "joint";
    case mjTRN_JOINTINPARENT: return "jointinparent";
    case mjTRN_TENDON: return "tendon";
    case mjTRN_SITE: return "site";
    case mjTRN_BODY: return "body";
    default: return "slidercrank";
  }
}

Json Vec(const double* v, int n) {
  Json a = Json::array();
  for (int i = 0; i < n; ++i) a.push_back(v[i]);
  return a;
}

int Run(const InspectFlags& flags) {
  sim::MjcfComposer composer(flags.file);
  if (flags.emit) {
    std::printf("%s", composer.Emit().c_str());
    return 0;
  }
  sim::ModelPtr m = composer.Compile();
  sim::DataPtr d = sim::MakeData(m.get());
  mj_kinematics(m.get(), d.get());
  using sim::MjName;
  Json out;
  out["file"] = flags.file;
  Json bodies = Json::array();
  for (int b = 0; b < m->nbody; ++b) {
    Json jb;
    jb["name"] = MjName(m.get(), mjOBJ_BODY, b);
    jb["parent"] = MjName(m.get(), mjOBJ_BODY, m->body_parentid[b]);
    jb["pos"] = Vec(d->xpos + 3 * b, 3);
    jb["quat"] = Vec(d->xquat + 4 * b, 4);
    jb["mass"] = m->body_mass[b];
    jb["ngeom"] = m->body_geomnum[b];
    std::array<double, 3> lo, hi;
    if (sim::BodyGeomBox(m.get(), d.get(), b, &lo, &hi)) {
      jb["aabb"] = {{"min", Vec(lo.data(), 3)}, {"max", Vec(hi.data(), 3)}};
    } else {
      jb["aabb"] = nullptr;
    }
    bodies.push_back(jb);
  }
  out["bodies"] = bodies;
  Json joints = Json::array();
  for (int j = 0; j < m->njnt; ++j) {
    Json jj = {{"name", MjName(m.get(), mjOBJ_JOINT, j)},
               {"type", JointType(m->jnt_type[j])},
               {"body", MjName(m.get(), mjOBJ_BODY, m->jnt_bodyid[j])}};
    jj["range"] = m->jnt_limited[j] ? Vec(m->jnt_range + 2 * j, 2) : Json(nullptr);
    joints.push_back(jj);
  }
  out["joints"] = joints;
  Json actuators = Json::array();
  for (int a = 0; a < m->nu; ++a) {
    int trn = m->actuator_trntype[a];
    mjtObj obj = trn == mjTRN_TENDON ? mjOBJ_TENDON
                 : trn == mjTRN_SITE ? mjOBJ_SITE
                 : trn == mjTRN_BODY ? mjOBJ_BODY
                                     : mjOBJ_JOINT;
    Json ja = {{"name", MjName(m.get(), mjOBJ_ACTUATOR, a)},
               {"transmission", TrnType(trn)},
               {"target", MjName(m.get(), obj, m->actuator_trnid[2 * a])}};
    ja["ctrlrange"] = m->actuator_ctrllimited[a] ? Vec(m->actuator_ctrlrange + 2 * a, 2)
                                                 : Json(nullptr);
    actuators.push_back(ja);
  }
  out["actuators"] = actuators;
  Json cameras = Json::array();
  for (int c = 0; c < m->ncam; ++c) {
    cameras.push_back({{"name", MjName(m.get(), mjOBJ_CAMERA, c)},
                       {"body", MjName(m.get(), mjOBJ_BODY, m->cam_bodyid[c])},
                       {"pos", Vec(d->cam_xpos + 3 * c, 3)},
                       {"fovy", m->cam_fovy[c]}});
  }
  out["cameras"] = cameras;
  Json warnings = Json::array();
  for (const std::string& w : composer.warnings()) warnings.push_back(w);
  out["warnings"] = warnings;
  if (flags.json) {
    std::printf("%s\n", DumpJsonIndent4(out).c_str());
    return 0;
  }
  // Text for people: 6 significant digits, names shown as "(unnamed)" when MuJoCo has none.
  auto vec = [](const Json& v) {
    std::string out = "[";
    for (size_t k = 0; k < v.size(); ++k) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%s%.6g", k ? ", " : "", v[k].get<double>());
      out += buf;
    }
    return out + "]";
  };
  auto name = [](const Json& item) {
    const std::string& n = item["name"].get_ref<const std::string&>();
    return n.empty() ? std::string("(unnamed)") : n;
  };
  // MuJoCo 3's sizes are mjtSize (64-bit).
  std::printf("%s: %lld bodies, %lld joints, %lld geoms, %lld actuators, %lld cameras\n",
              flags.file.c_str(), static_cast<long long>(m->nbody),
              static_cast<long long>(m->njnt), static_cast<long long>(m->ngeom),
              static_cast<long long>(m->nu), static_cast<long long>(m->ncam));
  std::printf("bodies (world pose at qpos0; box = world-axes box of the body's own geoms):\n");
  for (const Json& b : bodies) {
    std::printf("  %-24s pos %s quat %s mass %.6g", name(b).c_str(), vec(b["pos"]).c_str(),
                vec(b["quat"]).c_str(), b["mass"].get<double>());
    if (!b["aabb"].is_null()) {
      std::printf(" box %s..%s", vec(b["aabb"]["min"]).c_str(), vec(b["aabb"]["max"]).c_str());
    }
    std::printf("\n");
  }
  if (!joints.empty()) std::printf("joints:\n");
  for (const Json& j : joints) {
    std::printf("  %-24s %-6s body %s%s%s\n", name(j).c_str(), j["type"].get<std::string>().c_str(),
                j["body"].get<std::string>().c_str(), j["range"].is_null() ? "" : " range ",
                j["range"].is_null() ? "" : vec(j["range"]).c_str());
  }
  if (!actuators.empty()) std::printf("actuators:\n");
  for (const Json& a : actuators) {
    std::printf("  %-24s %s %s\n", name(a).c_str(), a["transmission"].get<std::string>().c_str(),
                a["target"].get<std::string>().c_str());
  }
  if (!cameras.empty()) std::printf("cameras:\n");
  for (const Json& c : cameras) {
    std::printf("  %-24s body %s pos %s\n", name(c).c_str(), c["body"].get<std::string>().c_str(),
                vec(c["pos"]).c_str());
  }
  for (const std::string& w : composer.warnings()) Warn(w);
  return 0;
}

}  // namespace

void AddInspect(CLI::App& app, Action& action) {
  auto flags = std::make_shared<InspectFlags>();
  CLI::App* sub = app.add_subcommand(
      "inspect", "Compose and compile an MJCF; print bodies, joints, actuators and cameras");
  sub->add_option("FILE", flags->file, "MJCF file (MuJoCo 3 <frame>/<attach> allowed)")
      ->required();
  sub->add_flag("--json", flags->json, "Print JSON for scripts");
  sub->add_flag("--emit-mjcf", flags->emit, "Print the flat MJCF handed to MuJoCo 2.2.2");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
