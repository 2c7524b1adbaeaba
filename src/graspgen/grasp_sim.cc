// Grasp simulation: the floating-gripper scene, the rigid approach/close/shake/twist test and
// the parallel, deterministic candidate loop (include/mlspaces/graspgen/grasp_sim.h,
// docs/graspgen.md "Simulation"). The articulated test is in grasp_sim_joint.cc.
#include "mlspaces/graspgen/grasp_sim.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <numbers>

#include "grasp_sim_internal.h"
#include "gripper_proxy.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::graspgen {
namespace {

constexpr const char* kHandBody = "graspgen_hand";
constexpr const char* kHandPrefix = "graspgen_hand/";
constexpr const char* kTargetBody = "graspgen_target";

// Rigid protocol constants (docs/graspgen.md "Simulation").
constexpr double kSimApproach = 0.02;  // m simulated before the grasp pose (the rest: geometry)
constexpr int kApproachSteps = 20;     // over kSimApproach (1 m/s: the path is known free)
constexpr int kHoldSteps = 10;         // open hand at the grasp pose
constexpr double kSweepStep = 0.005;   // m between open-hand checks on the approach line
constexpr int kReturnSteps = 15;       // back at the grasp pose after each shake

// The shake profile over one period, x in [0, 1]: peaks of +-1 at x = 1/3 and 2/3, at rest
// (zero velocity and acceleration) at both ends, so the hand never jerks the object.
double Shake(double x) {
  const double u = 2 * std::numbers::pi * x;
  return (std::sin(u) - 0.5 * std::sin(2 * u)) / 1.299038105676658;
}

// Translation distance and rotation angle between two rigid transforms (core/se3.h).
std::pair<double, double> PoseDelta(const Mat4& a, const Mat4& b) {
  return {TranslationDistance(a, b), RotationAngle(a, b)};
}

std::string Mm(double m) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f mm", m * 1000);
  return buf;
}

std::string Deg(double rad) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f deg", rad * 180 / std::numbers::pi);
  return buf;
}

}  // namespace

std::string ReasonClass(const std::string& reason) {
  const size_t colon = reason.find(':');
  return colon == std::string::npos ? reason : reason.substr(0, colon);
}

Mat4 BodyMat4(const mjData* d, int body) {
  return sim::FrameToMat4(d->xpos + 3 * body, d->xmat + 9 * body);
}

void GraspScene::Impl::SetTcp(mjData* d, const Mat4& tcp_world) const {
  const Pose p = ToPose(tcp_world * InverseRigid(mocap_to_tcp));
  sim::PoseToMj(p, d->mocap_pos + 3 * mocap, d->mocap_quat + 4 * mocap);
}

void GraspScene::Impl::PlaceHand(mjData* d, const Mat4& tcp_world) const {
  SetTcp(d, tcp_world);
  for (int k = 0; k < 3; ++k) d->qpos[hand_qpos + k] = d->mocap_pos[3 * mocap + k];
  for (int k = 0; k < 4; ++k) d->qpos[hand_qpos + 3 + k] = d->mocap_quat[4 * mocap + k];
  for (int k = 0; k < 6; ++k) d->qvel[hand_dof + k] = 0;
}

int GraspScene::Impl::FingerContacts(const mjData* d, const std::vector<char>& in_set) const {
  const mjModel* m = model.get();
  int sides = 0;
  for (int i = 0; i < d->ncon && sides != 3; ++i) {
    const mjContact& c = d->contact[i];
    if (c.exclude != 0) continue;
    const int g1 = c.geom[0], g2 = c.geom[1];
    if (geom_side[g1] != 0 && in_set[m->geom_bodyid[g2]]) sides |= geom_side[g1];
    if (geom_side[g2] != 0 && in_set[m->geom_bodyid[g1]]) sides |= geom_side[g2];
  }
  return sides;
}

int64_t GraspScene::Impl::Close(const mjModel* m, mjData* d,
                                const std::function<bool()>& abort) const {
  // The fingers are done when they have stopped for a few steps in a row (a squeeze reaches
  // its force within ~0.05 s of the fingers stopping); 0.6 s (the original's close) at most.
  constexpr int kMin = 40, kMax = 300, kStill = 10;
  d->ctrl[actuator] = closed_ctrl;
  int still = 0;
  int64_t n = 0;
  while (n < kMax) {
    mj_step(m, d);
    ++n;
    double v = 0;
    for (int dof : finger_dofs) v = std::max(v, std::abs(d->qvel[dof]));
    still = v < 0.02 ? still + 1 : 0;
    if (n >= kMin && still >= kStill) break;
    if (abort && n % 10 == 0 && abort()) break;
  }
  return n;
}

bool GraspScene::Impl::HandPathBlocked(const Mat4& tcp_in_root, const Vec3& away, double s_from,
                                       double s_to) const {
  if (!object_mesh) return false;
  const int n = std::max(1, static_cast<int>(std::ceil((s_to - s_from) / kSweepStep)));
  for (int i = 0; i <= n; ++i) {
    const double s = s_from + (s_to - s_from) * i / n;
    Mat4 t = tcp_in_root;
    for (int k = 0; k < 3; ++k) t(k, 3) += s * away[k];
    if (HandCollides(*object_mesh, proxy, t)) return true;
  }
  return false;
}

bool GraspScene::Impl::ApproachBlocked(const Mat4& tcp_in_root, double s_from, double s_to) const {
  const Vec3 back{-tcp_in_root(0, 2), -tcp_in_root(1, 2), -tcp_in_root(2, 2)};
  return HandPathBlocked(tcp_in_root, back, s_from, s_to);
}

GraspScene::GraspScene(const std::filesystem::path& asset_file, const robots::RobotSpec& robot,
                       Mode mode, const SimParams& params)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.mode = mode;
  s.params = params;
  s.source = asset_file.string();
  sim::MjcfComposer composer(asset_file);
  mjSpec* spec = composer.spec();
  mjsBody* world = mjs_findBody(spec, "world");
  mjsElement* first = mjs_firstChild(world, mjOBJ_BODY, 0);
  if (first == nullptr) throw Error("the asset has no body", s.source);
  mjsBody* root = mjs_asBody(first);

  // The object's root: free (rigid) or fixed (articulated), in this in-memory spec only.
  std::vector<mjsElement*> free_joints;
  for (mjsElement* e = mjs_firstChild(root, mjOBJ_JOINT, 0); e != nullptr;
       e = mjs_nextChild(root, e, 0)) {
    if (mjs_asJoint(e)->type == mjJNT_FREE) free_joints.push_back(e);
  }
  if (mode == Mode::kRigid && free_joints.empty()) {
    mjs_addJoint(root, nullptr)->type = mjJNT_FREE;
  } else if (mode == Mode::kArticulated) {
    for (mjsElement* e : free_joints) mjs_delete(spec, e);
  }

  // The original's scene options (spec 2.5.1), zero gravity.
  mjOption& o = spec->option;
  o.timestep = params.timestep;
  o.gravity[0] = o.gravity[1] = o.gravity[2] = 0;
  o.impratio = 10;
  o.integrator = mjINT_IMPLICITFAST;
  o.cone = mjCONE_ELLIPTIC;
  o.jacobian = mjJAC_DENSE;
  o.solver = mjSOL_NEWTON;
  o.noslip_iterations = 3;
  o.enableflags |= mjENBL_MULTICCD;
  o.disableflags &= ~(mjDSBL_CONTACT | mjDSBL_WARMSTART);

  // The hand: a free body holding the robot's gripper subtree (actuator, tendon, equalities),
  // welded to a mocap target as the original's floating Robotiq. A mocap body as the hand
  // itself does not work: MuJoCo moves mocap bodies by teleporting them (zero velocity), so
  // friction never drags a held object along (measured: the object stays put, docs).
  mjsBody* mocap = mjs_addBody(world, nullptr);
  mjs_setName(mocap->element, kTargetBody);
  mocap->mocap = 1;
  mjsBody* hand = mjs_addBody(world, nullptr);
  mjs_setName(hand->element, kHandBody);
  mjs_addJoint(hand, nullptr)->type = mjJNT_FREE;
  mjsEquality* weld = mjs_addEquality(spec, nullptr);
  weld->type = mjEQ_WELD;
  weld->objtype = mjOBJ_BODY;
  mjs_setString(weld->name1, kHandBody);
  mjs_setString(weld->name2, kTargetBody);
  for (double& v : weld->data) v = 0;
  weld->data[6] = 1;   // relative pose: identity
  weld->data[10] = 1;  // torque scale
  // The original robot class's weld (spec section 4); MuJoCo raises the time constant to
  // 2 timesteps.
  weld->solref[0] = 0.001;
  weld->solref[1] = 1;
  const double solimp[5] = {0.99, 0.99, 0.001, 0.5, 2};
  for (int i = 0; i < 5; ++i) weld->solimp[i] = solimp[i];
  composer.Attach(robot.xml, kHandBody, kHandPrefix, Pose{}, robot.gripper_body);
  if (mode == Mode::kRigid) AddSupport(spec);
  s.model = composer.Compile();
  const mjModel* m = s.model.get();

  const auto id = [&](mjtObj type, const std::string& name, const char* field) {
    const std::string full = kHandPrefix + name;
    const int i = mj_name2id(m, type, full.c_str());
    if (i < 0) {
      throw Error("gripper " + std::string(field) + " '" + name + "' is not in " +
                      robot.gripper_body + "'s subtree",
                  robot.description_file.string(), std::string("gripper.") + field);
    }
    return i;
  };
  const int hand_body = mj_name2id(m, mjOBJ_BODY, kHandBody);
  s.mocap = m->body_mocapid[mj_name2id(m, mjOBJ_BODY, kTargetBody)];
  s.hand_qpos = m->jnt_qposadr[m->body_jntadr[hand_body]];
  s.hand_dof = m->jnt_dofadr[m->body_jntadr[hand_body]];
  s.site = id(mjOBJ_SITE, robot.tcp_site, "tcp_site");
  s.actuator = id(mjOBJ_ACTUATOR, robot.gripper_actuator, "actuator");
  s.open_ctrl = robot.gripper_open_ctrl;
  s.closed_ctrl = robot.gripper_closed_ctrl;
  s.object = -1;
  for (int b = 1; b < m->nbody && s.object < 0; ++b) {
    if (m->body_parentid[b] == 0 && m->body_mocapid[b] < 0 && b != hand_body) s.object = b;
  }
  s.body_root.assign(m->nbody, 0);
  for (int b = 1; b < m->nbody; ++b) {
    s.body_root[b] = m->body_parentid[b] == 0 ? b : s.body_root[m->body_parentid[b]];
  }
  for (int j = 0; j < m->njnt; ++j) {
    if (s.body_root[m->jnt_bodyid[j]] == hand_body && m->jnt_type[j] == mjJNT_HINGE) {
      s.finger_dofs.push_back(m->jnt_dofadr[j]);
    }
  }

  // Finger sides: every geom in the subtree of the hand body that is the highest ancestor of
  // a finger pad below the gripper root (the finger's driver link) belongs to that finger.
  const int gripper_root = id(mjOBJ_BODY, robot.gripper_body, "body");
  s.geom_side.assign(m->ngeom, 0);
  for (int side = 0; side < 2; ++side) {
    const int pad = id(mjOBJ_GEOM, robot.finger_pads[side], "finger_pads");
    int chain = m->geom_bodyid[pad];
    while (m->body_parentid[chain] != gripper_root) {
      chain = m->body_parentid[chain];
      if (chain == 0) {
        throw Error(
            "finger pad '" + robot.finger_pads[side] + "' is not below " + robot.gripper_body,
            robot.description_file.string(), "gripper.finger_pads");
      }
    }
    for (int g = 0; g < m->ngeom; ++g) {
      int b = m->geom_bodyid[g];
      while (b != 0 && b != chain) b = m->body_parentid[b];
      if (b == chain) s.geom_side[g] = side + 1;
    }
  }

  // The hand's pose constants and its open-hand proxy, at qpos0 (fingers open).
  sim::DataPtr data = sim::MakeData(m);
  mj_forward(m, data.get());
  const Mat4 tcp = sim::SiteMat4(data.get(), s.site);
  s.mocap_to_tcp = InverseRigid(BodyMat4(data.get(), hand_body)) * tcp;
  const Mat4 world_to_tcp = InverseRigid(tcp);
  for (int g : sim::CollisionGeoms(m, hand_body)) {
    s.proxy.boxes.push_back(GeomBox(m, data.get(), g, world_to_tcp));
  }
  s.proxy.name = robot.name;
  if (s.object < 0) throw Error("the asset has no body", s.source);
  s.object_mesh.emplace(CollisionMesh(m, s.object, s.source));
  if (mode == Mode::kRigid) {
    s.support_mocap = m->body_mocapid[mj_name2id(m, mjOBJ_BODY, "graspgen_support")];
    s.support_model = SupportModel(m);
    s.support_z = INFINITY;
    for (const Vec3& v : s.object_mesh->mesh().vertices) s.support_z = std::min(s.support_z, v[2]);
  }
}

GraspScene::~GraspScene() = default;

const mjModel* GraspScene::model() const { return impl_->model.get(); }

const MeshBvh& GraspScene::object_mesh() const { return *impl_->object_mesh; }

SimOutcome GraspScene::TestRigid(const Mat4& tcp, mjData* data) const {
  const Impl& s = *impl_;
  const mjModel* m = s.model.get();
  SimOutcome out;
  if (s.mode != Mode::kRigid) throw Error("TestRigid needs a rigid-mode scene", s.source);
  // The rigid test's state between phases.
  struct RigidRun {
    const Impl& s;
    const mjModel* m;
    mjData* d;
    std::vector<char> object_bodies;
    Mat4 object_in_tcp;  // after closing
    int64_t steps = 0;

    Mat4 Tcp() const { return sim::SiteMat4(d, s.site); }
    Mat4 Object() const { return BodyMat4(d, s.object); }
    void Step() {
      mj_step(m, d);
      ++steps;
    }
    // "" when held by both fingers without slipping, else the failure reason.
    // Contact with both fingers (when `contact`) and no slip; "" when both hold.
    std::string Check(const std::string& when, bool contact = true) const {
      const int sides = contact ? s.FingerContacts(d, object_bodies) : 3;
      if (sides != 3) {
        return std::string(sides == 0 ? "lost" : "held by one finger") + " during " + when;
      }
      const auto [dist, angle] = PoseDelta(object_in_tcp, InverseRigid(Tcp()) * Object());
      if (dist > s.params.max_slip) return "slipped in the hand: " + Mm(dist) + " during " + when;
      if (angle > s.params.max_slip_angle) {
        return "turned in the hand: " + Deg(angle) + " during " + when;
      }
      return {};
    }
  };
  // Geometry first: the open hand must not touch the object anywhere on the approach line
  // from approach_distance back to the last kSimApproach, which is simulated.
  if (s.ApproachBlocked(tcp, kSimApproach, std::max(kSimApproach, s.params.approach_distance))) {
    out.reason = "approach path blocked";
    return out;
  }
  mj_resetData(m, data);
  mj_kinematics(m, data);
  RigidRun run{s, m, data, {}, {}};
  run.object_bodies.assign(m->nbody, 0);
  for (int b = 1; b < m->nbody; ++b) run.object_bodies[b] = s.body_root[b] == s.object;
  const Mat4 target = run.Object() * tcp;
  const Vec3 z{target(0, 2), target(1, 2), target(2, 2)};
  const auto back = [&](double dist) {
    return Translate({-dist * z[0], -dist * z[1], -dist * z[2]}) * target;
  };
  data->ctrl[s.actuator] = s.open_ctrl;
  s.PlaceHand(data, back(kSimApproach));
  mj_kinematics(m, data);
  const Mat4 object0 = run.Object();  // after placing the hand (the object does not move)
  for (int k = 1; k <= kApproachSteps + kHoldSteps; ++k) {
    s.SetTcp(data, back(kSimApproach * std::max(0, kApproachSteps - k) / kApproachSteps));
    run.Step();
  }
  {
    const auto [dist, angle] = PoseDelta(object0, run.Object());
    if (dist > kApproachMotion || angle > kApproachTurn) {
      out.reason = "approach moved the object: " + Mm(dist) + ", " + Deg(angle);
      out.steps = run.steps;
      return out;
    }
  }
  // A closing that pushes the object away is decided as soon as it has moved 2 cm.
  run.steps += s.Close(m, data, [&] { return PoseDelta(object0, run.Object()).first > 0.02; });
  if (s.FingerContacts(data, run.object_bodies) != 3) {
    const auto [dist, angle] = PoseDelta(object0, run.Object());
    out.reason =
        std::string(s.FingerContacts(data, run.object_bodies) == 0 ? "not held after closing"
                                                                   : "one finger after closing") +
        ": object moved " + Mm(dist) + ", " + Deg(angle);
    // Floating free, such an object also swings out of one finger at the first one's push.
    if (s.params.support_test && SupportClear(tcp) &&
        s.TestOnSupport(tcp, data, run.steps).empty()) {
      out.reason.clear();
      out.success = true;
      out.tcp = tcp;  // the pose the data engine commands, which held on the support
    }
    out.steps = run.steps;
    return out;
  }
  run.object_in_tcp = InverseRigid(run.Tcp()) * run.Object();
  out.tcp = InverseRigid(run.Object()) * run.Tcp();

  // Twist first (it rejects most of what fails after closing, so those stop soonest):
  // twist_angle about the approach axis through the TCP, contacts checked at each quarter.
  // The shake then holds the turned pose (a half turn: the gripper's own pose again).
  std::string reason;
  const int twist =
      std::max(4, static_cast<int>(std::lround(s.params.twist_period / s.params.timestep)));
  const Mat4 to_tcp = Translate(Translation(target));
  const Mat4 from_tcp = Translate({-target(0, 3), -target(1, 3), -target(2, 3)});
  const auto turned = [&](double angle) {
    return to_tcp * AxisAngle(z, angle) * from_tcp * target;
  };
  for (int k = 1; k <= twist + kReturnSteps && reason.empty(); ++k) {
    const double u = 2 * std::numbers::pi * std::min(k, twist) / twist;
    // 0 -> twist_angle, at rest at both ends.
    const double angle = s.params.twist_angle * (u - std::sin(u)) / (2 * std::numbers::pi);
    s.SetTcp(data, turned(angle));
    run.Step();
    if (k % (twist / 4) == 0 || k == twist + kReturnSteps) {
      reason = run.Check("twist");
    } else if (k % kSlipEvery == 0) {
      reason = run.Check("twist", false);
    }
  }
  const Mat4 held = turned(s.params.twist_angle);
  // Then the shake: one period of Shake() (peaks +-shake_amplitude) along world x, y, z; checked at
  // the two peaks and back at the grasp pose.
  const int period =
      std::max(4, static_cast<int>(std::lround(s.params.shake_period / s.params.timestep)));
  const char* axes[3] = {"shake x", "shake y", "shake z"};
  for (int axis = 0; axis < 3 && reason.empty(); ++axis) {
    for (int k = 1; k <= period + kReturnSteps && reason.empty(); ++k) {
      Vec3 offset{0, 0, 0};
      if (k <= period) offset[axis] = s.params.shake_amplitude * Shake(double(k) / period);
      s.SetTcp(data, Translate(offset) * held);
      run.Step();
      if (k == period / 3 || k == 2 * period / 3 || k == period + kReturnSteps) {
        reason = run.Check(axes[axis]);
      } else if (k % kSlipEvery == 0) {
        reason = run.Check(axes[axis], false);
      }
    }
  }
  if (reason.empty() && s.params.support_test && SupportClear(out.tcp)) {
    reason = s.TestOnSupport(out.tcp, data, run.steps);
  } else if (!reason.empty() && s.params.support_test && SupportClear(tcp)) {
    // Shaken in zero gravity, a heavy object held far from its centre of mass slips; resting
    // on its support and lifted, as the data engine picks it, it may hold: decided there.
    if (s.TestOnSupport(tcp, data, run.steps).empty()) {
      reason.clear();
      out.tcp = tcp;  // the pose the data engine commands, which held on the support
    }
  }
  out.steps = run.steps;
  out.reason = reason;
  out.success = reason.empty();
  if (!out.success) out.tcp = Mat4{};
  return out;
}

SimRun TestCandidates(const GraspScene& scene, const std::vector<GraspCandidate>& candidates,
                      const std::vector<size_t>& order, size_t max_success,
                      const JointTarget* target, const SimParams& params,
                      const SimProgress& progress) {
  SimRun run;
  if (max_success == 0 || order.empty()) return run;
  for (size_t i : order) {
    if (i >= candidates.size()) throw Error("candidate order index out of range");
  }
  const int threads = ParallelThreads(params.threads, order.size());
  // One mjData per thread, handed out from a stack (any free one: every test resets it).
  std::vector<sim::DataPtr> pool;
  pool.reserve(static_cast<size_t>(threads));
  for (int t = 0; t < threads; ++t) pool.push_back(sim::MakeData(scene.model()));
  std::vector<mjData*> free_data;
  free_data.reserve(pool.size());
  for (auto& d : pool) free_data.push_back(d.get());
  std::mutex mutex;
  // Candidates are tested in order on the worker threads, a few ahead of the calling thread,
  // which takes the outcomes in order up to the max_success-th success: what is kept and
  // counted is the same whatever the thread count (no barrier between batches, so a thread
  // never waits for another's long test).
  constexpr size_t kAhead = 4;  // per thread
  constexpr size_t kProgressEvery = 8;
  ParallelForOrdered<SimOutcome>(
      order.size(), threads, kAhead * static_cast<size_t>(threads),
      [&](size_t i) {
        mjData* d = nullptr;
        {
          std::lock_guard lock(mutex);
          d = free_data.back();
          free_data.pop_back();
        }
        SimOutcome o;
        try {
          const Mat4& tcp = candidates[order[i]].tcp;
          o = target ? scene.TestJoint(*target, tcp, d) : scene.TestRigid(tcp, d);
        } catch (...) {
          std::lock_guard lock(mutex);
          free_data.push_back(d);
          throw;
        }
        std::lock_guard lock(mutex);
        free_data.push_back(d);
        return o;
      },
      [&](size_t i, SimOutcome&& o) {
        ++run.tested;
        run.steps += o.steps;
        if (o.success) {
          run.accepted.push_back(order[i]);
          run.poses.push_back(o.tcp);
        } else {
          ++run.failures[ReasonClass(o.reason)];
        }
        const bool more = run.accepted.size() < max_success;
        if (progress && (!more || run.tested % kProgressEvery == 0 || i + 1 == order.size())) {
          progress(run.tested, run.accepted.size());
        }
        return more;
      });
  return run;
}

}  // namespace mlspaces::graspgen
