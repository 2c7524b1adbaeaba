#include "mlspaces/sim/scene.h"

#include <algorithm>
#include <cmath>

#include "mlspaces/core/error.h"
#include "mlspaces/library/scene_metadata.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {
namespace {

// MuJoCo's statistic centre and extent (engine_setconst.c, setStat: the box of the bodies'
// frames and centres of mass, the joints' anchors, the sites and the geoms with their bounding
// radii, at qpos0), of the bodies `left_out` does not mark only. Nothing left: m unchanged.
void RestrictStatistic(mjModel* m, const std::vector<char>& left_out, bool center, bool extent) {
  DataPtr d = MakeData(m);
  mj_kinematics(m, d.get());
  mjtNum lo[3] = {1e10, 1e10, 1e10}, hi[3] = {-1e10, -1e10, -1e10};
  auto add = [&](const mjtNum* p, mjtNum r) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k] - r);
      hi[k] = std::max(hi[k], p[k] + r);
    }
  };
  for (int b = 1; b < m->nbody; ++b) {
    if (left_out[b]) continue;
    add(d->xpos + 3 * b, 0);
    add(d->xipos + 3 * b, 0);
  }
  for (int j = 0; j < m->njnt; ++j) {
    if (!left_out[m->jnt_bodyid[j]]) add(d->xanchor + 3 * j, 0);
  }
  for (int s = 0; s < m->nsite; ++s) {
    if (!left_out[m->site_bodyid[s]]) add(d->site_xpos + 3 * s, 0);
  }
  for (int g = 0; g < m->ngeom; ++g) {
    if (left_out[m->geom_bodyid[g]]) continue;
    const mjtNum* size = m->geom_size + 3 * g;
    mjtNum r = m->geom_rbound[g];
    if (!(r > 0) && m->geom_type[g] == mjGEOM_PLANE) {
      r = size[0] != 0 || size[1] != 0 ? 0.1 * std::max(size[0], size[1]) : 0.01;
    } else if (!(r > 0) && m->geom_type[g] == mjGEOM_HFIELD) {
      const mjtNum* h = m->hfield_size + 4 * m->geom_dataid[g];
      r = 0.1 * std::max({h[0], h[1], h[2], h[3]});
    } else if (!(r > 0)) {
      r = 0;
    }
    add(d->geom_xpos + 3 * g, r);
  }
  if (!(hi[0] > lo[0])) return;
  if (center) {
    for (int k = 0; k < 3; ++k) m->stat.center[k] = 0.5 * (lo[k] + hi[k]);
  }
  if (extent) {
    const mjtNum box = std::max({1e-5, hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    m->stat.extent = std::max(box, 2 * m->stat.meansize);
  }
}

}  // namespace

Scene Scene::Load(const std::filesystem::path& xml, ComposeOptions options) {
  MjcfComposer composer(xml, options);
  std::optional<Json> meta = LoadSceneMetadata(xml);
  Json m = meta ? std::move(*meta) : Json{{"objects", Json::object()}};
  return Scene(std::move(composer), std::move(m), options);
}

std::string Scene::InsertAsset(const Registry& registry, std::string_view uid, const Pose& pose,
                               std::string_view parent_body, std::string_view prefix) {
  AssetLocation loc = registry.LocateOrThrow(uid);
  std::shared_ptr<const Annotation> annotation = registry.GetAnnotation(uid);
  if (!annotation) {
    throw Error("no metadata for " + std::string(uid) + " in library " + loc.library, "", "",
                std::string(uid));
  }
  Json entry = MakeInsertedObjectEntry(*annotation, loc.mjcf_path);
  std::string p = prefix.empty() ? std::string(uid) + "_" + std::to_string(inserted_) + "/"
                                 : std::string(prefix);
  // Parsed and checked first, so that a bad asset leaves the scene as it was.
  const MjcfComposer asset(loc.mjcf_path, options_);
  if (const size_t n = asset.TopLevelBodies().size(); n != 1) {
    throw Error(
        "an inserted asset must have exactly one top-level body, found " + std::to_string(n),
        loc.mjcf_path.string(), "", std::string(uid));
  }
  std::vector<std::string> bodies = composer_.Attach(asset, parent_body, p, pose);
  ++inserted_;
  AddSceneObject(metadata_, bodies[0], std::move(entry));
  return bodies[0];
}

void Scene::ExcludeFromStatistic(std::string prefix) {
  if (!prefix.empty()) excluded_.push_back(std::move(prefix));
}

ModelPtr Scene::Compile() const {
  ModelPtr m = composer_.Compile();
  const mjStatistic& set = composer_.spec()->stat;  // NaN: not set by the scene
  const bool center = std::isnan(set.center[0]), extent = std::isnan(set.extent);
  if (excluded_.empty() || !(center || extent)) return m;
  std::vector<char> left_out(m->nbody, 0);  // a body, or a body above it, named so
  bool any = false;
  for (int b = 1; b < m->nbody; ++b) {
    const char* name = mj_id2name(m.get(), mjOBJ_BODY, b);
    const std::string_view n = name != nullptr ? name : "";
    left_out[b] = left_out[m->body_parentid[b]];
    for (const std::string& p : excluded_) left_out[b] = left_out[b] || n.starts_with(p);
    any = any || left_out[b];
  }
  if (any) RestrictStatistic(m.get(), left_out, center, extent);
  return m;
}

std::vector<std::string> Scene::InsertRobot(const std::filesystem::path& robot_xml,
                                            std::string_view prefix, const Pose& base) {
  return composer_.Attach(robot_xml, "world", prefix, base);
}

std::vector<std::string> Scene::InsertRobotString(std::string_view xml,
                                                  const std::filesystem::path& path_for_errors,
                                                  std::string_view prefix, const Pose& base) {
  return composer_.AttachString(xml, path_for_errors, "world", prefix, base);
}

}  // namespace mlspaces::sim
