// The pick-and-place task samplers (tasks/pick_and_place/sampler.h).
#include "mlspaces/datagen/tasks/pick_and_place/sampler.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/tasks/pick/success.h"
#include "mlspaces/datagen/tasks/pick_and_place/success.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::datagen {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr std::string_view kPrefix = "place_receptacle/";
constexpr double kZEps = 0.003;  // receptacle bottom above the support top
// The least xy gap between the placed receptacle's AABB and the object's (the original asks
// only for no contact, and fingers closing on the object can then hit the receptacle).
constexpr double kGraspClearance = 0.05;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

int RootOf(const mjModel* m, int body) {
  while (body > 0 && m->body_parentid[body] != 0) body = m->body_parentid[body];
  return body;
}

// The receptacle assets of the user libraries (the spec A.5.2 filter).
std::vector<std::string> ReceptacleUids(const Registry& registry,
                                        const std::vector<std::string>& types) {
  std::vector<std::string> out;
  for (const std::string& uid : registry.user_uids()) {
    const std::shared_ptr<const Annotation> a = registry.GetAnnotation(uid);
    if (!a || !a->json.is_object()) continue;
    const Json& j = a->json;
    if (!j.value("receptacle", false)) continue;
    if (j.value("primaryProperty", std::string()) != "CanPickup") continue;
    const auto bb = j.find("boundingBox");
    if (bb == j.end() || !bb->is_object()) continue;
    const double x = bb->value("x", 0.0), y = bb->value("y", 0.0), z = bb->value("z", 1.0);
    if (!(x > 0.17 && x <= 0.5 && y > 0.17 && y <= 0.5 && z <= 0.15)) continue;
    if (!types.empty()) {
      const std::string cat = Lower(j.value("category", std::string()));
      bool hit = false;
      for (const std::string& t : types) hit = hit || Lower(t) == cat;
      if (!hit) continue;
    }
    out.push_back(uid);
  }
  return out;
}

// Contacts of body `root`'s subtree with anything whose root is not `root` or `allowed`.
bool TouchesOthers(const mjModel* m, const mjData* d, int root, int allowed) {
  for (int c = 0; c < d->ncon; ++c) {
    const int r1 = RootOf(m, m->geom_bodyid[d->contact[c].geom1]);
    const int r2 = RootOf(m, m->geom_bodyid[d->contact[c].geom2]);
    if (r1 != root && r2 != root) continue;
    const int other = r1 == root ? r2 : r1;
    if (other != root && other != allowed) return true;
  }
  return false;
}

// The xy extent of a geom when it is a box (else unbounded: planes, meshes).
bool GeomXyExtent(const mjModel* m, const mjData* d, int geom, double lo[2], double hi[2]) {
  if (geom < 0 || m->geom_type[geom] != mjGEOM_BOX) return false;
  const mjtNum* r = d->geom_xmat + 9 * geom;
  const mjtNum* s = m->geom_size + 3 * geom;
  for (int i = 0; i < 2; ++i) {
    const double half =
        std::abs(r[3 * i]) * s[0] + std::abs(r[3 * i + 1]) * s[1] + std::abs(r[3 * i + 2]) * s[2];
    lo[i] = d->geom_xpos[3 * geom + i] - half;
    hi[i] = d->geom_xpos[3 * geom + i] + half;
  }
  return true;
}

Pose WithYaw(const Pose& staged, double x, double y, double z, double yaw) {
  Pose p;
  p.pos = {x, y, z};
  p.quat = QuatMul({std::cos(yaw / 2), 0, 0, std::sin(yaw / 2)}, staged.quat);
  return p;
}

}  // namespace

const std::vector<NamedColor>& PlaceColors() {
  static const std::vector<NamedColor> colors = {{"red", {1, 0, 0}},
                                                 {"blue", {0, 0, 1}},
                                                 {"green", {0, 1, 0}},
                                                 {"yellow", {1, 1, 0}},
                                                 {"purple", {0.5f, 0, 0.5f}},
                                                 {"orange", {1, 0.5f, 0}},
                                                 {"black", {0, 0, 0}},
                                                 {"white", {1, 1, 1}},
                                                 {"brown", {0.55f, 0.35f, 0.15f}},
                                                 {"tan", {0.82f, 0.71f, 0.55f}},
                                                 {"light_blue", {0.68f, 0.85f, 0.90f}},
                                                 {"light_green", {0.56f, 0.93f, 0.56f}},
                                                 {"light_yellow", {1, 1, 0.88f}}};
  return colors;
}

bool IsPickAndPlaceTask(TaskType type) {
  return type == TaskType::kPickAndPlace || type == TaskType::kPickAndPlaceNextTo ||
         type == TaskType::kPickAndPlaceColor;
}

std::vector<std::string> PlaceReceptacles(const Env& env) {
  const mjModel* m = env.model();
  std::vector<std::string> out;
  for (int b = 1; b < m->nbody; ++b) {
    if (m->body_parentid[b] != 0 || m->body_jntnum[b] != 1) continue;
    if (m->jnt_type[m->body_jntadr[b]] != mjJNT_FREE) continue;
    std::string name = sim::MjName(m, mjOBJ_BODY, b);
    if (name.starts_with(kPrefix)) out.push_back(std::move(name));
  }
  return out;
}

PickAndPlaceTaskSampler::PickAndPlaceTaskSampler(const ExperimentConfig& config, uint64_t run_seed)
    : TaskSampler(config, run_seed),
      registry_(std::make_unique<Registry>(Registry::Options{config.libraries.assets_dir})) {
  config.libraries.ApplyTo(*registry_);
}

PickAndPlaceTaskSampler::~PickAndPlaceTaskSampler() = default;

void PickAndPlaceTaskSampler::AddAuxiliaryObjects(sim::Scene& scene) {
  const ExperimentConfig& cfg = config();
  if (cfg.task_type == TaskType::kPickAndPlaceNextTo) return;  // targets are scene objects
  const TaskSamplerConfig& s = cfg.task_sampler_config;
  std::vector<std::string> uids = ReceptacleUids(*registry_, s.place_receptacle_types);
  if (uids.empty()) {
    throw Error(
        "no receptacle asset in the user libraries (annotation receptacle: true, primaryProperty "
        "CanPickup, boundingBox x, y in (0.17, 0.5] m, z <= 0.15 m" +
            std::string(s.place_receptacle_types.empty() ? "" : ", of the listed categories") + ")",
        "", "task_sampler_config.place_receptacle_types");
  }
  // Drawn once per scene from the run seed and the scene, as the original draws per load.
  Rng rng(DeriveSeed(run_seed(), {HashString(scene.composer().path().generic_string()), 7}));
  const size_t n = std::min(uids.size(), static_cast<size_t>(s.num_place_receptacles));
  for (size_t i = 0; i < n; ++i) {  // partial Fisher-Yates: without replacement
    std::swap(uids[i], uids[i + rng.UniformInt(uids.size() - i)]);
  }
  uids.resize(n);
  const int copies = cfg.task_type == TaskType::kPickAndPlaceColor ? 2 : 1;
  // The static staging floor the unused receptacles rest on, far above the scene.
  const double hx = 0.5 * static_cast<double>(n) + 0.5, hy = 0.5 * copies + 0.5;
  const std::string floor =
      "<mujoco><worldbody><body name=\"staging_floor\"><geom name=\"staging_floor\" "
      "type=\"box\" size=\"" +
      std::to_string(hx) + " " + std::to_string(hy) +
      " 0.5\" contype=\"8\" conaffinity=\"15\" group=\"4\"/></body></worldbody></mujoco>";
  scene.InsertRobotString(floor, scene.composer().path(), kPrefix, Pose{{5, 5, 35}, {1, 0, 0, 0}});
  // The parked receptacles leave the scene's scale as it was (the original's parking made the
  // extent 35 m: its cameras clipped everything within 0.35 m, the gripper included).
  scene.ExcludeFromStatistic(std::string(kPrefix));
  for (size_t i = 0; i < n; ++i) {
    for (int j = 0; j < copies; ++j) {
      const Pose at{{5.0 - 0.5 * static_cast<double>(n) + 0.5 + static_cast<double>(i),
                     5.0 - 0.5 * copies + 0.5 + j, 35.5 + kZEps},
                    {1, 0, 0, 0}};
      scene.InsertAsset(*registry_, uids[i], at, "world",
                        std::string(kPrefix) + std::to_string(i) + "_" + std::to_string(j) + "/");
    }
  }
}

void PickAndPlaceTaskSampler::SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) {
  const ExperimentConfig& cfg = config();
  const TaskSamplerConfig& s = cfg.task_sampler_config;
  const std::string& object = *draft.pickup_obj_name;
  // Robot base, then the object, as block_pickup.
  auto draw = [&rng](double a) { return rng.Uniform(-std::abs(a), std::abs(a)); };
  {
    const PlanarNoise& nb = s.robot_base_noise;
    const double rx = draw(nb.x), ry = draw(nb.y), ryaw = draw(nb.yaw_deg) * kDeg;
    env.SetRobotBasePose(ComposePlanar(env.GetRobotBasePose(), rx, ry, ryaw));
    const PlanarNoise& no = s.object_noise;
    const double ox = draw(no.x), oy = draw(no.y), oyaw = draw(no.yaw_deg) * kDeg;
    env.SetBodyPose(object, ComposePlanar(env.GetBodyPose(object), ox, oy, oyaw));
    env.ForwardPosition();
  }
  const mjModel* m = env.model();
  mjData* d = env.data();
  const int obj = env.BodyId(object);
  const Pose base = env.GetRobotBasePose();
  const std::array<Vec3, 2> obj_box = SubtreeAabb(m, d, obj);
  const double obj_cx = 0.5 * (obj_box[0][0] + obj_box[1][0]);
  const double obj_cy = 0.5 * (obj_box[0][1] + obj_box[1][1]);
  TaskPlace place;

  if (cfg.task_type == TaskType::kPickAndPlaceNextTo) {
    // A scene object on the same surface level, at a centre distance in the band.
    std::vector<std::string> targets;
    const Json& objects = env.metadata().value("objects", Json::object());
    for (const auto& [body, entry] : objects.items()) {
      (void)entry;
      if (body == object || body.starts_with(kPrefix)) continue;
      if (cfg.task_config.place_receptacle_name && body != *cfg.task_config.place_receptacle_name)
        continue;
      const int b = mj_name2id(m, mjOBJ_BODY, body.c_str());
      if (b < 0) continue;
      const std::array<Vec3, 2> box = SubtreeAabb(m, d, b);
      if (box[0][0] > box[1][0] || std::abs(box[0][2] - obj_box[0][2]) > 0.05) continue;
      const double dx = 0.5 * (box[0][0] + box[1][0]) - obj_cx;
      const double dy = 0.5 * (box[0][1] + box[1][1]) - obj_cy;
      const double dist = std::hypot(dx, dy);
      if (dist < s.min_object_to_receptacle_dist || dist > s.max_object_to_receptacle_dist)
        continue;
      targets.push_back(body);
    }
    if (targets.empty()) {
      throw TaskRejected("no scene object on the pickup's surface at a centre distance in [" +
                         std::to_string(s.min_object_to_receptacle_dist) + ", " +
                         std::to_string(s.max_object_to_receptacle_dist) + "] m from " + object);
    }
    place.receptacle = targets[rng.UniformInt(targets.size())];
    place.receptacle_start_pose = sim::BodyPose(d, env.BodyId(place.receptacle));
  } else {
    std::vector<std::string> all = PlaceReceptacles(env);
    // The receptacles of the chosen uid (copies share "<i>_"): one per copy.
    std::vector<std::string> chosen;
    if (const auto& preset = cfg.task_config.place_receptacle_name) {
      if (std::find(all.begin(), all.end(), *preset) == all.end()) {
        throw Error("task_config.place_receptacle_name '" + *preset +
                        "' is not a receptacle added to the scene " + env.scene_key(),
                    "", "task_config.place_receptacle_name");
      }
      chosen.push_back(*preset);
      const std::string stem = preset->substr(0, preset->find('_', kPrefix.size()) + 1);
      for (const std::string& r : all)
        if (r != *preset && r.starts_with(stem)) chosen.push_back(r);
    } else {
      std::vector<std::string> stems;
      for (const std::string& r : all) {
        const std::string stem = r.substr(0, r.find('_', kPrefix.size()) + 1);
        if (std::find(stems.begin(), stems.end(), stem) == stems.end()) stems.push_back(stem);
      }
      if (stems.empty()) throw Error("the scene " + env.scene_key() + " has no receptacles");
      // The original's rotation: the same receptacle for episodes_per_receptacle episodes in
      // a row, then the next, wrapping (0: the next every episode). Computed from the episode
      // number, not a counter, so an episode does not depend on the ones sampled before it.
      const int64_t per = std::max<int64_t>(1, s.episodes_per_receptacle);
      const int64_t slot = std::max<int64_t>(0, episode()) / per;
      const std::string& stem =
          stems[static_cast<size_t>(slot % static_cast<int64_t>(stems.size()))];
      for (const std::string& r : all)
        if (r.starts_with(stem)) chosen.push_back(r);
    }
    // The support under the object.
    const PickSuccess rest = EvaluatePickSuccess(m, d, obj, 0, env.robot().prefix, 0.0);
    if (rest.supporting_geom < 0) {
      throw TaskRejected("nothing supports " + object + " from below: no surface for a receptacle");
    }
    const int support_root = RootOf(m, m->geom_bodyid[rest.supporting_geom]);
    const double support_top = obj_box[0][2];
    double lo[2] = {0, 0}, hi[2] = {0, 0};  // set when bounded
    const bool bounded = GeomXyExtent(m, d, rest.supporting_geom, lo, hi);
    for (size_t k = 0; k < chosen.size(); ++k) {
      const std::string& r = chosen[k];
      const int rb = env.BodyId(r);
      const Pose staged = env.GetBodyPose(r);
      const std::array<Vec3, 2> rbox0 = SubtreeAabb(m, d, rb);
      const double rx_half = 0.5 * (rbox0[1][0] - rbox0[0][0]);
      const double ry_half = 0.5 * (rbox0[1][1] - rbox0[0][1]);
      bool placed = false;
      for (int64_t t = 0; t < s.max_place_receptacle_sampling_attempts && !placed; ++t) {
        const double dist =
            rng.Uniform(s.min_object_to_receptacle_dist, s.max_object_to_receptacle_dist);
        const double az = rng.Uniform(-std::numbers::pi, std::numbers::pi);
        const double yaw = rng.Uniform(-std::numbers::pi, std::numbers::pi);
        const Pose obj_pose = env.GetBodyPose(object);
        const double x = obj_pose.pos[0] + dist * std::cos(az);
        const double y = obj_pose.pos[1] + dist * std::sin(az);
        if (std::hypot(x - base.pos[0], y - base.pos[1]) > s.max_robot_to_place_receptacle_dist)
          continue;
        if (bounded && (x < lo[0] + 0.5 * rx_half || x > hi[0] - 0.5 * rx_half ||
                        y < lo[1] + 0.5 * ry_half || y > hi[1] - 0.5 * ry_half))
          continue;
        env.SetBodyPose(r, WithYaw(staged, x, y, staged.pos[2], yaw));
        env.ForwardPosition();
        const std::array<Vec3, 2> box = SubtreeAabb(m, d, rb);
        env.SetBodyPose(
            r, WithYaw(staged, x, y, staged.pos[2] + (support_top + kZEps - box[0][2]), yaw));
        env.ForwardPosition();
        // Touching nothing but the support, and a finger's clearance (kGraspClearance)
        // from the object so the grasp does not hit the receptacle.
        const std::array<Vec3, 2> at = SubtreeAabb(m, d, rb);
        const std::array<Vec3, 2> ob = SubtreeAabb(m, d, obj);
        const double gx = std::max({0.0, at[0][0] - ob[1][0], ob[0][0] - at[1][0]});
        const double gy = std::max({0.0, at[0][1] - ob[1][1], ob[0][1] - at[1][1]});
        placed = std::hypot(gx, gy) >= kGraspClearance && !TouchesOthers(m, d, rb, support_root);
      }
      if (!placed) {
        env.SetBodyPose(r, staged);
        env.ForwardPosition();
        throw TaskRejected("no room for receptacle " + r + " within " +
                           std::to_string(s.max_place_receptacle_sampling_attempts) +
                           " tries around " + object);
      }
      if (k == 0) {
        place.receptacle = r;
        place.receptacle_start_pose = env.GetBodyPose(r);
      } else {
        place.other_receptacles.push_back(r);
        place.other_receptacle_start_poses.push_back(env.GetBodyPose(r));
      }
    }
    if (cfg.task_type == TaskType::kPickAndPlaceColor) {
      // Target colour uniform; each distractor a different one (runtime rgba, as the
      // original writes model.geom_rgba).
      const std::vector<NamedColor>& colors = PlaceColors();
      std::vector<size_t> order(colors.size());
      for (size_t i = 0; i < order.size(); ++i) order[i] = i;
      for (size_t i = 0; i + 1 < order.size(); ++i)
        std::swap(order[i], order[i + rng.UniformInt(order.size() - i)]);
      auto paint = [&](const std::string& body, const NamedColor& c) {
        mjModel* mm = const_cast<mjModel*>(m);  // colours only: the variant's runtime state
        const int root = env.BodyId(body);
        for (int g = 0; g < m->ngeom; ++g) {
          if (RootOf(m, m->geom_bodyid[g]) != root) continue;
          mm->geom_matid[g] = -1;
          for (int i = 0; i < 3; ++i) mm->geom_rgba[4 * g + i] = c.rgb[i];
        }
      };
      paint(place.receptacle, colors[order[0]]);
      place.color = std::string(colors[order[0]].name);
      for (size_t k = 0; k < place.other_receptacles.size(); ++k)
        paint(place.other_receptacles[k], colors[order[1 + k % (order.size() - 1)]]);
    }
  }
  env.ForwardPosition();
  draft.robot_base_pose = env.GetRobotBasePose();
  draft.pickup_obj_start_pose = env.GetBodyPose(object);
  Pose goal = *draft.pickup_obj_start_pose;
  goal.pos[2] += 0.05;  // the original's (unused by success)
  draft.pickup_obj_goal_pose = goal;
  draft.place = std::move(place);
}

void RegisterPickAndPlaceSamplers(TaskSamplerRegistry& registry) {
  auto make = [](const ExperimentConfig& config, uint64_t seed) {
    return std::make_unique<PickAndPlaceTaskSampler>(config, seed);
  };
  registry.Register("PickAndPlaceTaskSampler", make);
  registry.Register("PickAndPlaceReceptacleTaskSampler", make);
  registry.Register("PickAndPlaceNextToTaskSampler", make);
  registry.Register("PickAndPlaceColorTaskSampler", make);
}

}  // namespace mlspaces::datagen
