#include "mlspaces/robots/inspect.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/robots/ik.h"
#include "mlspaces/robots/insert.h"
#include "mlspaces/robots/robot_spec.h"
#include "mlspaces/robots/robot_view.h"
#include "mlspaces/sim/describe.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/scene.h"

namespace mlspaces::robots {
namespace {

namespace fs = std::filesystem;

constexpr char kPrefix[] = "robot_0/";
constexpr double kPi = 3.14159265358979323846;

// The empty world the robot is measured in: a floor, the robot's own integrator settings.
constexpr char kSceneXml[] = R"(<mujoco model="inspect_robot">
  <option timestep="0.002" integrator="implicitfast" cone="elliptic" impratio="10"/>
  <worldbody><geom name="floor" type="plane" size="3 3 0.1"/></worldbody>
</mujoco>
)";

std::string Format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string Format(const char* fmt, ...) {
  va_list args, again;
  va_start(args, fmt);
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, args);
  va_end(args);
  std::string out(n > 0 ? static_cast<size_t>(n) : 0, '\0');
  std::vsnprintf(out.data(), out.size() + 1, fmt, again);
  va_end(again);
  return out;
}

std::string Indexed(const std::string& key, size_t i) {
  return key + "[" + std::to_string(i) + "]";
}

Vec3 Column(const Mat4& t, int c) { return {t(0, c), t(1, c), t(2, c)}; }
Vec3 ToVec3(const mjtNum* v) { return {v[0], v[1], v[2]}; }
// Angle between two non-zero vectors, degrees; `either_sign`: of the line through b.
double AngleDeg(const Vec3& a, const Vec3& b, bool either_sign = false) {
  double c = Dot(a, b) / (Norm(a) * Norm(b));
  if (either_sign) c = std::abs(c);
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / kPi;
}

// Collects problem lines "<file>: <field>: <problem>", each once.
struct Problems {
  std::string file;
  std::vector<std::string>* lines;
  void Add(const std::string& field, const std::string& message) const {
    std::string line = Error(message, file, field).what();
    if (std::find(lines->begin(), lines->end(), line) == lines->end()) lines->push_back(line);
  }
  // True when a line about `field` is already there (CheckRobotDescription's own).
  bool Has(const std::string& field) const {
    const std::string tag = ": " + field + ": ";
    return std::any_of(lines->begin(), lines->end(),
                       [&](const std::string& l) { return l.find(tag) != std::string::npos; });
  }
};

void CheckRange(const std::array<double, 2>& r, const char* field) {
  if (!std::isfinite(r[0]) || !std::isfinite(r[1]) || r[0] > r[1]) {
    throw UsageError(Format("must be [min, max] with finite min <= max, got [%g, %g]", r[0], r[1]),
                     "", field);
  }
}

int GridCount(const std::array<double, 2>& r, double step) {
  return static_cast<int>(std::floor((r[1] - r[0]) / step + 1e-9)) + 1;
}

// Grid point i of range r (never past max by rounding).
double GridPoint(const std::array<double, 2>& r, double step, int i) {
  return std::min(r[0] + i * step, r[1]);
}

void CheckOptions(const InspectOptions& o) {
  if (!(o.settle_time > 0 && o.settle_time <= 60)) {
    throw UsageError(Format("must be in (0, 60] seconds, got %g", o.settle_time), "",
                     "settle_time");
  }
  if (!(o.finger_tolerance >= 0 && std::isfinite(o.finger_tolerance))) {
    throw UsageError(Format("must be >= 0 metres, got %g", o.finger_tolerance), "",
                     "finger_tolerance");
  }
  if (!(o.tcp_tolerance_deg >= 0 && o.tcp_tolerance_deg <= 180)) {
    throw UsageError(Format("must be in [0, 180] degrees, got %g", o.tcp_tolerance_deg), "",
                     "tcp_tolerance_deg");
  }
  CheckRange(o.grid_x, "grid_x");
  CheckRange(o.grid_y, "grid_y");
  CheckRange(o.grid_z, "grid_z");
  if (!(o.grid_step > 0 && std::isfinite(o.grid_step))) {
    throw UsageError(Format("must be > 0 metres, got %g", o.grid_step), "", "grid_step");
  }
  const double n = static_cast<double>(GridCount(o.grid_x, o.grid_step)) *
                   GridCount(o.grid_y, o.grid_step) * GridCount(o.grid_z, o.grid_step);
  if (n > 100000) {
    throw UsageError(Format("%.0f grid points; at most 100000 (a larger step)", n), "",
                     "grid_step");
  }
}

// Composes the empty world (sim::Scene reads a file: a temp file, removed at once).
sim::Scene EmptyScene() {
  const fs::path file =
      fs::temp_directory_path() / ("mlspaces_inspect_robot" + TempSuffix() + ".xml");
  WriteFileAtomic(file, kSceneXml, /*sync=*/false);
  try {
    sim::Scene scene = sim::Scene::Load(file);
    std::error_code ec;
    fs::remove(file, ec);
    return scene;
  } catch (...) {
    std::error_code ec;
    fs::remove(file, ec);
    throw;
  }
}

std::string Unprefixed(const char* name) {
  std::string s = name == nullptr ? "" : name;
  if (s.starts_with(kPrefix)) s.erase(0, sizeof kPrefix - 1);
  return s;
}

ActuatorReport DescribeActuator(const mjModel* m, int a) {
  ActuatorReport r;
  r.name = Unprefixed(mj_id2name(m, mjOBJ_ACTUATOR, a));
  const int id = m->actuator_trnid[2 * a];
  switch (m->actuator_trntype[a]) {
    case mjTRN_JOINT:
    case mjTRN_JOINTINPARENT:
      r.target = "joint " + Unprefixed(mj_id2name(m, mjOBJ_JOINT, id));
      break;
    case mjTRN_TENDON:
      r.target = "tendon " + Unprefixed(mj_id2name(m, mjOBJ_TENDON, id));
      break;
    case mjTRN_SITE:
      r.target = "site " + Unprefixed(mj_id2name(m, mjOBJ_SITE, id));
      break;
    case mjTRN_BODY:
      r.target = "body " + Unprefixed(mj_id2name(m, mjOBJ_BODY, id));
      break;
    default:
      r.target = "other";
  }
  if (m->actuator_ctrllimited[a]) {
    r.ctrl_range = {m->actuator_ctrlrange[2 * a], m->actuator_ctrlrange[2 * a + 1]};
  }
  if (m->actuator_forcelimited[a]) {
    r.force_range = {m->actuator_forcerange[2 * a], m->actuator_forcerange[2 * a + 1]};
  }
  r.gain = m->actuator_gainprm[mjNGAIN * a];
  for (int k = 0; k < 3; ++k) r.bias[k] = m->actuator_biasprm[mjNBIAS * a + k];
  return r;
}

// Everything after the robot is compiled into `m`.
class Inspector {
 public:
  Inspector(const RobotDescription& d, const mjModel* m, const InspectOptions& o, RobotReport& r)
      : d_(d), m_(m), o_(o), r_(r), p_{d.file.string(), &r.problems} {}

  void Run() {
    Resolve();
    Chain();
    Actuators();
    data_ = sim::MakeData(m_);
    SetHome();
    Home();
    Tcp();
    Reachability();
    GripperTravel();  // last: it moves the gripper (and the arm settles)
  }

 private:
  int Id(mjtObj type, const std::string& name) const {
    return mj_name2id(m_, type, (kPrefix + name).c_str());
  }

  // The spec of the robot's names that are in the model (a missing arm joint drops it and
  // its servo; the IK then needs the whole arm), and the view over it when it resolves.
  void Resolve() {
    spec_ = MakeRobotSpec(d_, kPrefix);
    RobotSpec& s = spec_;
    std::vector<std::string> joints, actuators;
    std::vector<double> home;
    for (size_t i = 0; i < d_.arm.joints.size(); ++i) {
      const std::string act = i < s.arm_actuators.size() ? s.arm_actuators[i] : d_.arm.joints[i];
      const int j = Id(mjOBJ_JOINT, d_.arm.joints[i]);
      const bool one_dof =
          j >= 0 && (m_->jnt_type[j] == mjJNT_HINGE || m_->jnt_type[j] == mjJNT_SLIDE);
      if (one_dof && i < d_.arm.home.size())
        home_qpos_.emplace_back(m_->jnt_qposadr[j], d_.arm.home[i]);
      if (!one_dof || Id(mjOBJ_ACTUATOR, act) < 0 || i >= d_.arm.home.size()) {
        arm_complete_ = false;
        continue;
      }
      joints.push_back(d_.arm.joints[i]);
      actuators.push_back(act);
      home.push_back(d_.arm.home[i]);
      arm_joint_ids_.push_back(j);
      arm_index_.push_back(i);
    }
    s.arm_joints = joints;
    s.arm_actuators = actuators;
    s.home_arm = home;
    std::vector<std::string> gjoints;
    std::vector<double> ghome;
    for (size_t i = 0; i < d_.gripper.joints.size(); ++i) {
      const int j = Id(mjOBJ_JOINT, d_.gripper.joints[i]);
      if (j < 0 || i >= d_.gripper.home.size()) continue;
      gjoints.push_back(d_.gripper.joints[i]);
      ghome.push_back(d_.gripper.home[i]);
      gripper_joint_ids_.push_back(j);
      gripper_index_.push_back(i);
    }
    s.gripper_joints = gjoints;
    s.home_gripper = ghome;
    s.mirrored_joints.clear();
    for (const auto& pair : d_.gripper.mirrored) {
      if (Id(mjOBJ_JOINT, pair[0]) >= 0 && Id(mjOBJ_JOINT, pair[1]) >= 0) {
        s.mirrored_joints.emplace_back(pair[0], pair[1]);
      }
    }
    site_ = Id(mjOBJ_SITE, d_.tcp_site);
    root_ = Id(mjOBJ_BODY, d_.root_body);
    gripper_body_ = Id(mjOBJ_BODY, d_.gripper.body);
    pads_ = {Id(mjOBJ_GEOM, d_.gripper.finger_pads[0]), Id(mjOBJ_GEOM, d_.gripper.finger_pads[1])};
    base_ = Id(mjOBJ_BODY, s.base_body);
    try {
      view_ = std::make_unique<RobotView>(m_, s);
    } catch (const Error& e) {
      view_error_ = e.what();
    }
  }

  // Bodies root_body .. the TCP site's body; arm joints on it, in order, and nothing unlisted.
  void Chain() {
    if (root_ < 0 || site_ < 0) return;
    std::vector<int> bodies;
    int b = m_->site_bodyid[site_];
    for (; b > 0 && b != root_; b = m_->body_parentid[b]) bodies.push_back(b);
    if (b != root_) {
      p_.Add("tcp_site", "site '" + d_.tcp_site + "' is not in the subtree of root_body '" +
                             d_.root_body + "'");
      return;
    }
    bodies.push_back(root_);
    std::reverse(bodies.begin(), bodies.end());
    std::vector<int> chain_joints;  // joint ids in chain order
    for (int body : bodies) {
      ChainBody cb;
      cb.name = Unprefixed(mj_id2name(m_, mjOBJ_BODY, body));
      for (int j = m_->body_jntadr[body];
           j >= 0 && j < m_->body_jntadr[body] + m_->body_jntnum[body]; ++j) {
        ChainJoint cj;
        cj.name = Unprefixed(mj_id2name(m_, mjOBJ_JOINT, j));
        cj.type = sim::JointTypeName(m_->jnt_type[j]);
        cj.axis = ToVec3(m_->jnt_axis + 3 * j);
        if (m_->jnt_limited[j]) cj.range = {{m_->jnt_range[2 * j], m_->jnt_range[2 * j + 1]}};
        cj.arm =
            std::find(d_.arm.joints.begin(), d_.arm.joints.end(), cj.name) != d_.arm.joints.end();
        if (!cj.arm) {
          p_.Add("arm.joints", "joint '" + cj.name + "' on the chain from root_body to tcp_site" +
                                   " is not listed (nothing would move it)");
        }
        chain_joints.push_back(j);
        cb.joints.push_back(std::move(cj));
      }
      r_.chain.push_back(std::move(cb));
    }
    ptrdiff_t last = -1;
    std::string last_name;
    for (size_t k = 0; k < arm_joint_ids_.size(); ++k) {
      const auto it = std::find(chain_joints.begin(), chain_joints.end(), arm_joint_ids_[k]);
      const std::string& name = d_.arm.joints[arm_index_[k]];
      if (it == chain_joints.end()) {
        p_.Add(Indexed("arm.joints", arm_index_[k]),
               "joint '" + name + "' is not on the chain from root_body '" + d_.root_body +
                   "' to tcp_site '" + d_.tcp_site + "'");
        continue;
      }
      const ptrdiff_t at = it - chain_joints.begin();
      if (at < last) {
        p_.Add("arm.joints", "not in order from base to tip: '" + name + "' comes before '" +
                                 last_name + "' on the chain");
      }
      last = at;
      last_name = name;
    }
  }

  void Actuators() {
    for (size_t k = 0; k < spec_.arm_actuators.size(); ++k) {
      r_.arm_actuators.push_back(DescribeActuator(m_, Id(mjOBJ_ACTUATOR, spec_.arm_actuators[k])));
    }
    if (const int a = Id(mjOBJ_ACTUATOR, d_.gripper.actuator); a >= 0) {
      r_.gripper_actuator = DescribeActuator(m_, a);
    }
    r_.arm_dof = static_cast<int>(arm_joint_ids_.size());
    r_.gripper_drivers = static_cast<int>(gripper_joint_ids_.size());
    if (gripper_body_ >= 0) {
      for (int j = 0; j < m_->njnt; ++j) {
        if (sim::InSubtree(m_, m_->jnt_bodyid[j], gripper_body_)) {
          const int t = m_->jnt_type[j];
          r_.gripper_dof += t == mjJNT_FREE ? 6 : t == mjJNT_BALL ? 3 : 1;
        }
      }
    }
    r_.robot_nq = m_->nq;
    r_.robot_nv = m_->nv;
  }

  // The home pose as Env::Reset sets it: arm and gripper drivers, followers at minus their
  // driver, arm servos holding home.
  void SetHome() {
    mjData* d = data_.get();
    mj_resetData(m_, d);
    for (const auto& [adr, value] : home_qpos_) d->qpos[adr] = value;  // servo or not
    for (size_t k = 0; k < arm_joint_ids_.size(); ++k) {
      d->ctrl[Id(mjOBJ_ACTUATOR, spec_.arm_actuators[k])] = spec_.home_arm[k];
    }
    for (size_t k = 0; k < gripper_joint_ids_.size(); ++k) {
      d->qpos[m_->jnt_qposadr[gripper_joint_ids_[k]]] = spec_.home_gripper[k];
    }
    for (const auto& [follower, driver] : spec_.mirrored_joints) {
      d->qpos[m_->jnt_qposadr[Id(mjOBJ_JOINT, follower)]] =
          -d->qpos[m_->jnt_qposadr[Id(mjOBJ_JOINT, driver)]];
    }
    mj_forward(m_, d);
  }

  Mat4 BasePose() const {
    if (base_ < 0) return Mat4{};
    return sim::FrameToMat4(data_->xpos + 3 * base_, data_->xmat + 9 * base_);
  }

  void Home() {
    auto check = [&](const std::vector<int>& ids, const std::vector<size_t>& index,
                     const std::vector<double>& values, const std::string& key,
                     const std::vector<std::string>& names) {
      for (size_t k = 0; k < ids.size(); ++k) {
        const int j = ids[k];
        if (!m_->jnt_limited[j]) continue;
        const double lo = m_->jnt_range[2 * j], hi = m_->jnt_range[2 * j + 1];
        if (values[k] >= lo && values[k] <= hi) continue;
        r_.home.within_limits = false;
        const std::string field = Indexed(key, index[k]);
        if (!p_.Has(field)) {
          p_.Add(field, Format("%g is outside joint '%s''s range [%g, %g]", values[k],
                               names[index[k]].c_str(), lo, hi));
        }
      }
    };
    check(arm_joint_ids_, arm_index_, spec_.home_arm, "arm.home", d_.arm.joints);
    check(gripper_joint_ids_, gripper_index_, spec_.home_gripper, "gripper.home",
          d_.gripper.joints);
    if (site_ < 0) {
      r_.home.skipped = "tcp_site '" + d_.tcp_site + "' is not in the model";
      return;
    }
    r_.home.tcp = ToPose(InverseRigid(BasePose()) * sim::SiteMat4(data_.get(), site_));
  }

  void Tcp() {
    TcpReport& t = r_.tcp;
    if (site_ < 0 || gripper_body_ < 0 || pads_[0] < 0 || pads_[1] < 0) {
      t.skipped = "needs tcp_site, gripper.body and both gripper.finger_pads in the model";
      return;
    }
    const mjData* d = data_.get();
    const Mat4 tcp = sim::SiteMat4(d, site_);
    const Vec3 p0 = ToVec3(d->geom_xpos + 3 * pads_[0]), p1 = ToVec3(d->geom_xpos + 3 * pads_[1]);
    const Vec3 mid{(p0[0] + p1[0]) / 2, (p0[1] + p1[1]) / 2, (p0[2] + p1[2]) / 2};
    const Vec3 palm_to_pads = Sub(mid, ToVec3(d->xpos + 3 * gripper_body_));
    const Vec3 across = Sub(p1, p0);
    if (Norm(palm_to_pads) < 1e-6 || Norm(across) < 1e-6) {
      t.skipped =
          "the finger pads' centres coincide with each other or with the gripper body's "
          "origin: no direction to compare";
      return;
    }
    t.approach_angle_deg = AngleDeg(Column(tcp, 2), palm_to_pads);
    t.finger_axis_angle_deg = AngleDeg(Column(tcp, 1), across, /*either_sign=*/true);
    const Vec3 rel = Sub(mid, Translation(tcp));
    for (int k = 0; k < 3; ++k) t.pad_midpoint_in_tcp[k] = Dot(Column(tcp, k), rel);
    t.ok = t.approach_angle_deg <= o_.tcp_tolerance_deg &&
           t.finger_axis_angle_deg <= o_.tcp_tolerance_deg;
    if (t.approach_angle_deg > o_.tcp_tolerance_deg) {
      p_.Add("tcp_site",
             Format("+z is %.1f deg from the palm-to-fingertips direction at home (gripper.body "
                    "'%s' to the finger pads' midpoint); the convention wants them within %g deg",
                    t.approach_angle_deg, d_.gripper.body.c_str(), o_.tcp_tolerance_deg));
    }
    if (t.finger_axis_angle_deg > o_.tcp_tolerance_deg) {
      p_.Add("tcp_site",
             Format("the finger pads lie along a line %.1f deg from the TCP's y axis at home; the "
                    "convention wants the fingers to open along +-y (within %g deg)",
                    t.finger_axis_angle_deg, o_.tcp_tolerance_deg));
    }
  }

  void Reachability() {
    ReachabilityReport& rr = r_.reachability;
    rr.grid_x = o_.grid_x;
    rr.grid_y = o_.grid_y;
    rr.grid_z = o_.grid_z;
    rr.grid_step = o_.grid_step;
    if (!o_.reachability) {
      rr.skipped = "not asked for";
      return;
    }
    if (site_ < 0 || !arm_complete_ || arm_joint_ids_.empty()) {
      rr.skipped = "needs tcp_site and every arm joint with its servo in the model";
      return;
    }
    std::vector<std::string> joints;
    for (const std::string& j : spec_.arm_joints) joints.push_back(kPrefix + j);
    std::unique_ptr<IkSolver> solver;
    try {
      solver = std::make_unique<IkSolver>(m_, kPrefix + d_.tcp_site, joints, spec_.home_arm);
    } catch (const std::invalid_argument& e) {
      rr.skipped = e.what();
      return;
    }
    solver->SyncState(data_.get());
    // TCP pointing down; its x axis the home TCP's x turned horizontal (base +x if vertical).
    const Mat4 base = BasePose();
    const Mat4 home = InverseRigid(base) * sim::SiteMat4(data_.get(), site_);
    Vec3 x{home(0, 0), home(1, 0), 0};
    if (Norm(x) < 1e-6) x = {home(0, 1), home(1, 1), 0};
    if (Norm(x) < 1e-6) x = {1, 0, 0};
    const double n = Norm(x);
    x = {x[0] / n, x[1] / n, 0};
    const Vec3 z{0, 0, -1};
    const Vec3 y{z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
    const Rot3 rot{x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]};
    const int nx = GridCount(o_.grid_x, o_.grid_step), ny = GridCount(o_.grid_y, o_.grid_step),
              nz = GridCount(o_.grid_z, o_.grid_step);
    auto At = [&](const std::array<double, 2>& r, int i) { return GridPoint(r, o_.grid_step, i); };
    std::array<Vec3, 2> env{};
    for (int i = 0; i < nx; ++i) {
      for (int j = 0; j < ny; ++j) {
        for (int k = 0; k < nz; ++k) {
          const Vec3 p{At(o_.grid_x, i), At(o_.grid_y, j), At(o_.grid_z, k)};
          ++rr.targets;
          if (!solver->Solve(base * ToMat4(p, rot), spec_.home_arm).success) continue;
          if (rr.reached++ == 0) env = {p, p};
          for (int a = 0; a < 3; ++a) {
            env[0][a] = std::min(env[0][a], p[a]);
            env[1][a] = std::max(env[1][a], p[a]);
          }
        }
      }
    }
    if (rr.reached > 0) rr.envelope = env;
  }

  void GripperTravel() {
    GripperTravelReport& g = r_.gripper;
    g.settle_time = o_.settle_time;
    g.gravcomp = spec_.gravcomp;
    g.declared = d_.gripper.finger_range;
    if (!view_) {
      g.skipped = view_error_;
      return;
    }
    mjData* d = data_.get();
    const int steps = std::max(1, static_cast<int>(std::lround(o_.settle_time / m_->opt.timestep)));
    auto settle = [&](double ctrl) {
      view_->SetGripperCtrl(d, ctrl);
      view_->Step(d, steps);
      mj_forward(m_, d);
      return view_->InterFingerDistance(d);
    };
    g.open_gap = settle(d_.gripper.open_ctrl);
    g.closed_gap = settle(d_.gripper.closed_ctrl);
    const double tol = o_.finger_tolerance;
    const bool closed_ok = std::abs(g.closed_gap - g.declared[0]) <= tol;
    const bool open_ok = std::abs(g.open_gap - g.declared[1]) <= tol;
    g.ok = closed_ok && open_ok;
    auto report = [&](size_t k, const char* state, double ctrl, double gap) {
      p_.Add(Indexed("gripper.finger_range", k),
             Format("the %s gap measured in simulation is %.4f m (ctrl %g, %g s), robot.yaml says "
                    "%.4f m: more than %g mm off",
                    state, gap, ctrl, o_.settle_time, g.declared[k], tol * 1000));
    };
    if (!closed_ok) report(0, "closed", d_.gripper.closed_ctrl, g.closed_gap);
    if (!open_ok) report(1, "open", d_.gripper.open_ctrl, g.open_gap);
  }

  const RobotDescription& d_;
  const mjModel* m_;
  const InspectOptions& o_;
  RobotReport& r_;
  Problems p_;
  RobotSpec spec_;
  std::unique_ptr<RobotView> view_;
  std::string view_error_;
  sim::DataPtr data_;
  bool arm_complete_ = true;
  std::vector<int> arm_joint_ids_, gripper_joint_ids_;
  std::vector<size_t> arm_index_, gripper_index_;  // their index in robot.yaml's lists
  std::vector<std::pair<int, double>> home_qpos_;  // every arm joint found: qpos adr, home
  int site_ = -1, root_ = -1, gripper_body_ = -1, base_ = -1;
  std::array<int, 2> pads_{-1, -1};
};

}  // namespace

RobotReport InspectRobot(std::string_view name_or_path, const InspectOptions& options) {
  CheckOptions(options);
  RobotReport r;
  r.file = FindRobot(name_or_path, fs::current_path(), "robot");
  std::optional<RobotDescription> d;
  r.problems = CheckRobotDescription(r.file, &d);
  // Nothing more to go on: the YAML did not read, or the MJCF is missing or does not compile
  // (the hash is set once it compiled).
  if (!d || d->hash.empty()) return r;
  r.file = d->file;
  r.name = d->name;
  r.hash = d->hash;
  sim::ModelPtr model;
  try {
    sim::Scene scene = EmptyScene();
    const RobotSpec spec = MakeRobotSpec(*d, kPrefix);
    InsertRobot(scene, spec);
    model = scene.Compile();
    ApplyRobotSettings(model.get(), spec);
  } catch (const Error& e) {
    const Problems p{d->file.string(), &r.problems};
    p.Add("mjcf", std::string("the robot cannot be inserted into a scene: ") + e.what());
    return r;
  }
  r.loaded = true;
  Inspector(*d, model.get(), options, r).Run();
  return r;
}

namespace {

Json Range(const std::optional<std::array<double, 2>>& r) {
  return r ? Json::array({(*r)[0], (*r)[1]}) : Json(nullptr);
}

Json ActuatorJson(const ActuatorReport& a) {
  return Json{{"name", a.name},
              {"target", a.target},
              {"ctrl_range", Range(a.ctrl_range)},
              {"force_range", Range(a.force_range)},
              {"gain", a.gain},
              {"bias", a.bias}};
}

Json Skipped(const std::string& why) { return why.empty() ? Json(nullptr) : Json(why); }

std::string Vec(const double* v, int n, const char* fmt = "%.4g") {
  std::string out = "[";
  for (int k = 0; k < n; ++k) {
    if (k) out += ", ";
    char buf[32];
    std::snprintf(buf, sizeof buf, fmt, std::abs(v[k]) < 5e-10 ? 0.0 : v[k]);  // no "-0", 1e-17
    out += buf;
  }
  return out + "]";
}
template <size_t N>
std::string Vec(const std::array<double, N>& v, const char* fmt = "%.4g") {
  return Vec(v.data(), static_cast<int>(N), fmt);
}

std::string RangeText(const std::optional<std::array<double, 2>>& r) {
  return r ? Vec(*r) : std::string("unlimited");
}

std::string ActuatorText(const ActuatorReport& a) {
  return Format("  %-26s %-28s ctrl %-20s force %-14s gain %g bias %s\n", a.name.c_str(),
                a.target.c_str(), RangeText(a.ctrl_range).c_str(), RangeText(a.force_range).c_str(),
                a.gain, Vec(a.bias).c_str());
}

}  // namespace

Json ToJson(const RobotReport& r) {
  Json out{{"file", r.file.string()},
           {"name", r.name},
           {"hash", r.hash},
           {"loaded", r.loaded},
           {"problems", r.problems}};
  if (!r.loaded) return out;
  Json chain = Json::array();
  for (const ChainBody& b : r.chain) {
    Json joints = Json::array();
    for (const ChainJoint& j : b.joints) {
      joints.push_back(Json{{"name", j.name},
                            {"type", j.type},
                            {"axis", j.axis},
                            {"range", Range(j.range)},
                            {"arm", j.arm}});
    }
    chain.push_back(Json{{"body", b.name}, {"joints", std::move(joints)}});
  }
  out["chain"] = std::move(chain);
  Json arm = Json::array();
  for (const ActuatorReport& a : r.arm_actuators) arm.push_back(ActuatorJson(a));
  out["actuators"] =
      Json{{"arm", std::move(arm)},
           {"gripper", r.gripper_actuator ? ActuatorJson(*r.gripper_actuator) : Json(nullptr)}};
  out["dof"] = Json{{"arm", r.arm_dof},
                    {"gripper", r.gripper_dof},
                    {"gripper_drivers", r.gripper_drivers},
                    {"robot_nq", r.robot_nq},
                    {"robot_nv", r.robot_nv}};
  out["home"] = Json{{"skipped", Skipped(r.home.skipped)},
                     {"within_limits", r.home.within_limits},
                     {"tcp_pos", r.home.tcp.pos},
                     {"tcp_quat", r.home.tcp.quat}};
  out["tcp"] = Json{{"skipped", Skipped(r.tcp.skipped)},
                    {"ok", r.tcp.ok},
                    {"approach_angle_deg", r.tcp.approach_angle_deg},
                    {"finger_axis_angle_deg", r.tcp.finger_axis_angle_deg},
                    {"pad_midpoint_in_tcp", r.tcp.pad_midpoint_in_tcp}};
  out["gripper_travel"] =
      Json{{"skipped", Skipped(r.gripper.skipped)}, {"ok", r.gripper.ok},
           {"settle_time", r.gripper.settle_time},  {"gravcomp", r.gripper.gravcomp},
           {"closed_gap", r.gripper.closed_gap},    {"open_gap", r.gripper.open_gap},
           {"finger_range", r.gripper.declared}};
  const ReachabilityReport& rr = r.reachability;
  Json envelope = nullptr;
  if (rr.envelope) {
    envelope = Json{{"min", (*rr.envelope)[0]}, {"max", (*rr.envelope)[1]}};
  }
  out["reachability"] = Json{{"skipped", Skipped(rr.skipped)},
                             {"grid_x", rr.grid_x},
                             {"grid_y", rr.grid_y},
                             {"grid_z", rr.grid_z},
                             {"grid_step", rr.grid_step},
                             {"targets", rr.targets},
                             {"reached", rr.reached},
                             {"fraction", rr.targets ? double(rr.reached) / rr.targets : 0.0},
                             {"envelope", std::move(envelope)}};
  return out;
}

std::string FormatRobotReport(const RobotReport& r) {
  std::string out;
  auto problems = [&] {
    for (const std::string& line : r.problems) out += line + "\n";
  };
  if (!r.loaded) {
    problems();
    return out;
  }
  out +=
      Format("robot %s: %s (hash %s)\n", r.name.c_str(), r.file.string().c_str(), r.hash.c_str());
  out += "kinematic chain (root body to the TCP site's body; joint axes in the body frame):\n";
  for (const ChainBody& b : r.chain) {
    out += "  " + b.name + "\n";
    for (const ChainJoint& j : b.joints) {
      out += Format("    %-24s %-5s axis %-16s range %s%s\n", j.name.c_str(), j.type.c_str(),
                    Vec(j.axis, "%.3g").c_str(), RangeText(j.range).c_str(),
                    j.arm ? "" : "  (not an arm joint)");
    }
  }
  out += Format("dof: arm %d, gripper %d (%d drivers), robot nq %d nv %d\n", r.arm_dof,
                r.gripper_dof, r.gripper_drivers, r.robot_nq, r.robot_nv);
  out += "actuators:\n";
  for (const ActuatorReport& a : r.arm_actuators) out += ActuatorText(a);
  if (r.gripper_actuator) out += ActuatorText(*r.gripper_actuator);
  if (!r.home.skipped.empty()) {
    out += "home: not measured (" + r.home.skipped + ")\n";
  } else {
    out += Format("home: %s; TCP at %s m, quat (wxyz) %s in the base frame\n",
                  r.home.within_limits ? "within the joint limits" : "OUTSIDE the joint limits",
                  Vec(r.home.tcp.pos).c_str(), Vec(r.home.tcp.quat).c_str());
  }
  const TcpReport& t = r.tcp;
  if (!t.skipped.empty()) {
    out += "TCP convention: not checked (" + t.skipped + ")\n";
  } else {
    out += Format(
        "TCP convention: %s (+z %.1f deg from palm-to-fingertips, pads %.1f deg from "
        "+-y, pad midpoint in the TCP frame %s m)\n",
        t.ok ? "OK" : "PROBLEM", t.approach_angle_deg, t.finger_axis_angle_deg,
        Vec(t.pad_midpoint_in_tcp).c_str());
  }
  const GripperTravelReport& g = r.gripper;
  if (!g.skipped.empty()) {
    out += "gripper travel: not measured (" + g.skipped + ")\n";
  } else {
    out += Format(
        "gripper travel (%g s per state, gravcomp %s): closed %.4f m, open %.4f m; "
        "finger_range %s: %s\n",
        g.settle_time, g.gravcomp ? "on" : "off", g.closed_gap, g.open_gap, Vec(g.declared).c_str(),
        g.ok ? "OK" : "PROBLEM");
  }
  const ReachabilityReport& rr = r.reachability;
  if (!rr.skipped.empty()) {
    out += "reachability: not measured (" + rr.skipped + ")\n";
  } else {
    out += Format(
        "reachability (IK from home, TCP pointing down; grid x %s y %s z %s step %g m, "
        "base frame): %d of %d reached (%.1f%%)",
        Vec(rr.grid_x).c_str(), Vec(rr.grid_y).c_str(), Vec(rr.grid_z).c_str(), rr.grid_step,
        rr.reached, rr.targets, rr.targets ? 100.0 * rr.reached / rr.targets : 0.0);
    if (rr.envelope) {
      const auto& e = *rr.envelope;
      out += Format("; reached x %s y %s z %s", Vec(std::array{e[0][0], e[1][0]}).c_str(),
                    Vec(std::array{e[0][1], e[1][1]}).c_str(),
                    Vec(std::array{e[0][2], e[1][2]}).c_str());
    }
    out += "\n";
  }
  if (r.problems.empty()) {
    out += "problems: none\n";
  } else {
    out += Format("problems: %zu\n", r.problems.size());
    problems();
  }
  return out;
}

}  // namespace mlspaces::robots
