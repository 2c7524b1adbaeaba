// The franka_droid robot model (assets/robots/franka_droid): names, limits, forward kinematics
// against Franka's modified-DH table, TCP frame, gripper widths, grasp holding, and MuJoCo's
// gravity compensation (body gravcomp) on the robot.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;
const fs::path kRobot =
    fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid/franka_droid.xml";
constexpr double kPi = 3.14159265358979323846;

// Published FR3 modified (Craig) DH parameters: a_{i-1}, d_i, alpha_{i-1} per joint.
struct DhRow {
  double a, d, alpha;
};
constexpr std::array<DhRow, 7> kDh = {{{0, 0.333, 0},
                                       {0, 0, -kPi / 2},
                                       {0, 0.316, kPi / 2},
                                       {0.0825, 0, kPi / 2},
                                       {-0.0825, 0.384, -kPi / 2},
                                       {0, 0, kPi / 2},
                                       {0.088, 0, kPi / 2}}};
constexpr double kFlangeD = 0.107;
constexpr double kTcpOffset = 0.14;  // flange -> grasp_site along flange z (the model's choice)
constexpr std::array<double, 7> kHomeArm = {0, -0.7853, 0, -2.35619, 0, 1.57079, 0};
constexpr std::array<double, 2> kHomeGripper = {0.00296, 0.00296};
constexpr std::array<double, 7> kLower = {-2.9007, -1.8361, -2.9007, -3.0770,
                                          -2.8763, 0.4398,  -3.0508};
constexpr std::array<double, 7> kUpper = {2.9007, 1.8361, 2.9007, -0.1169, 2.8763, 4.6216, 3.0508};
constexpr std::array<double, 7> kKp = {4500, 4500, 3500, 3500, 2000, 2000, 2000};

// Row-major homogeneous transform.
using Mat4 = std::array<double, 16>;

Mat4 Identity() { return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; }

Mat4 Mul(const Mat4& a, const Mat4& b) {
  Mat4 c{};
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      for (int k = 0; k < 4; ++k) c[4 * i + j] += a[4 * i + k] * b[4 * k + j];
    }
  }
  return c;
}

Mat4 RotX(double t) {
  const double c = std::cos(t), s = std::sin(t);
  return {1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0, 0, 0, 0, 1};
}

Mat4 RotZ(double t) {
  const double c = std::cos(t), s = std::sin(t);
  return {c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
}

Mat4 Trans(double x, double y, double z) {
  Mat4 t = Identity();
  t[3] = x;
  t[7] = y;
  t[11] = z;
  return t;
}

// Pose (pos, wxyz quat) -> transform, written out by hand.
Mat4 FromPose(const Pose& p) {
  const double w = p.quat[0], x = p.quat[1], y = p.quat[2], z = p.quat[3];
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  const double a = w / n, b = x / n, c = y / n, e = z / n;
  return {1 - 2 * (c * c + e * e),
          2 * (b * c - a * e),
          2 * (b * e + a * c),
          p.pos[0],
          2 * (b * c + a * e),
          1 - 2 * (b * b + e * e),
          2 * (c * e - a * b),
          p.pos[1],
          2 * (b * e - a * c),
          2 * (c * e + a * b),
          1 - 2 * (b * b + c * c),
          p.pos[2],
          0,
          0,
          0,
          1};
}

// World pose of the DH flange frame: base * prod_i RotX(alpha) TransX(a) RotZ(q) TransZ(d).
Mat4 DhFlange(const Pose& base, const std::array<double, 7>& q) {
  Mat4 t = FromPose(base);
  for (int i = 0; i < 7; ++i) {
    t = Mul(t, RotX(kDh[i].alpha));
    t = Mul(t, Trans(kDh[i].a, 0, 0));
    t = Mul(t, RotZ(q[i]));
    t = Mul(t, Trans(0, 0, kDh[i].d));
  }
  return Mul(t, Trans(0, 0, kFlangeD));
}

// A site's world transform from MuJoCo.
Mat4 SiteTransform(const mjData* d, int site) {
  const mjtNum* r = d->site_xmat + 9 * site;
  const mjtNum* p = d->site_xpos + 3 * site;
  return {r[0], r[1], r[2], p[0], r[3], r[4], r[5], p[1], r[6], r[7], r[8], p[2], 0, 0, 0, 1};
}

double MaxAbsDiff(const Mat4& a, const Mat4& b) {
  double e = 0;
  for (int i = 0; i < 12; ++i) e = std::max(e, std::abs(a[i] - b[i]));
  return e;
}

const char* kBareScene = R"(<mujoco model="robot_test">
  <option timestep="0.002" integrator="implicit"/>
  <worldbody><light pos="0 0 3" dir="0 0 -1"/></worldbody>
</mujoco>)";

// Composes `scene_xml` with the robot under "robot_0/" at `base`.
ModelPtr Compose(const std::string& scene_xml, const Pose& base = {}) {
  MjcfComposer composer =
      MjcfComposer::FromString(scene_xml, fs::path(MLSPACES_SOURCE_DIR) / "franka_droid_scene.xml");
  const auto tops = composer.Attach(kRobot, "world", "robot_0/", base);
  EXPECT_EQ(tops, std::vector<std::string>{"robot_0/base"});
  ModelPtr m = composer.Compile();
  EXPECT_TRUE(composer.warnings().empty()) << sim::MujocoWarningLine(composer.warnings().front());
  return m;
}

int Id(const mjModel* m, mjtObj type, const std::string& name) {
  const int id = mj_name2id(m, type, name.c_str());
  EXPECT_GE(id, 0) << name;
  return id;
}

std::string ArmJoint(int i) { return "robot_0/fr3_joint" + std::to_string(i + 1); }

// Handles on a compiled robot.
struct Robot {
  explicit Robot(const mjModel* model) : m(model) {
    for (int i = 0; i < 7; ++i) {
      const int j = Id(m, mjOBJ_JOINT, ArmJoint(i));
      arm_qpos[i] = m->jnt_qposadr[j];
      arm_dof[i] = m->jnt_dofadr[j];
      arm_act[i] = Id(m, mjOBJ_ACTUATOR, ArmJoint(i));
    }
    for (int k = 0; k < 2; ++k) {
      const std::string side = k == 0 ? "left" : "right";
      driver_qpos[k] =
          m->jnt_qposadr[Id(m, mjOBJ_JOINT, "robot_0/gripper/" + side + "_driver_joint")];
      pad[k] = Id(m, mjOBJ_GEOM, "robot_0/gripper/" + side + "_pad2");
    }
    fingers = Id(m, mjOBJ_ACTUATOR, "robot_0/gripper/fingers_actuator");
    tcp = Id(m, mjOBJ_SITE, "robot_0/gripper/grasp_site");
    flange = Id(m, mjOBJ_SITE, "robot_0/fr3_flange");
    base_mocap = m->body_mocapid[Id(m, mjOBJ_BODY, "robot_0/base")];
  }

  // Home pose in qpos, servo targets = home, gripper ctrl given.
  void SetHome(mjData* d, double gripper_ctrl = 0) const {
    for (int i = 0; i < 7; ++i) {
      d->qpos[arm_qpos[i]] = kHomeArm[i];
      d->ctrl[arm_act[i]] = kHomeArm[i];
    }
    for (int k = 0; k < 2; ++k) d->qpos[driver_qpos[k]] = kHomeGripper[k];
    d->ctrl[fingers] = gripper_ctrl;
  }

  void Step(mjData* d) const { mj_step(m, d); }

  // Inner-face distance between the pads along the TCP's y axis.
  double PadGap(const mjData* d) const {
    const mjtNum* r = d->site_xmat + 9 * tcp;
    const double y_axis[3] = {r[1], r[4], r[7]};
    double gap = 0;
    for (int c = 0; c < 3; ++c) {
      gap += (d->geom_xpos[3 * pad[0] + c] - d->geom_xpos[3 * pad[1] + c]) * y_axis[c];
    }
    return gap - m->geom_size[3 * pad[0] + 1] - m->geom_size[3 * pad[1] + 1];
  }

  // A point in the TCP frame.
  std::array<double, 3> InTcp(const mjData* d, const mjtNum* world) const {
    const mjtNum* r = d->site_xmat + 9 * tcp;
    const mjtNum* p = d->site_xpos + 3 * tcp;
    std::array<double, 3> out{};
    for (int a = 0; a < 3; ++a) {
      for (int c = 0; c < 3; ++c) out[a] += r[3 * c + a] * (world[c] - p[c]);
    }
    return out;
  }

  const mjModel* m;
  std::array<int, 7> arm_qpos{}, arm_dof{}, arm_act{};
  std::array<int, 2> driver_qpos{}, pad{};
  int fingers = -1, tcp = -1, flange = -1, base_mocap = -1;
};

TEST(FrankaDroid, NamesLiveUnderTheRobotPrefix) {
  ModelPtr m = Compose(kBareScene);
  const mjModel* mm = m.get();
  const int base = Id(mm, mjOBJ_BODY, "robot_0/base");
  EXPECT_GE(mm->body_mocapid[base], 0) << "robot_0/base must be a mocap body";
  EXPECT_EQ(mm->body_parentid[Id(mm, mjOBJ_BODY, "robot_0/fr3_link0")], base);
  for (int i = 0; i <= 7; ++i) Id(mm, mjOBJ_BODY, "robot_0/fr3_link" + std::to_string(i));
  for (int i = 0; i < 7; ++i) {
    const int j = Id(mm, mjOBJ_JOINT, ArmJoint(i));
    EXPECT_EQ(mm->jnt_type[j], mjJNT_HINGE);
    const int a = Id(mm, mjOBJ_ACTUATOR, ArmJoint(i));
    EXPECT_EQ(mm->actuator_trntype[a], mjTRN_JOINT);
    EXPECT_EQ(mm->actuator_trnid[2 * a], j);
  }
  for (const char* name :
       {"robot_0/gripper/base", "robot_0/gripper/left_driver", "robot_0/gripper/right_driver",
        "robot_0/gripper/left_follower", "robot_0/gripper/right_follower"}) {
    Id(mm, mjOBJ_BODY, name);
  }
  Id(mm, mjOBJ_JOINT, "robot_0/gripper/left_driver_joint");
  Id(mm, mjOBJ_JOINT, "robot_0/gripper/right_driver_joint");
  const int fingers = Id(mm, mjOBJ_ACTUATOR, "robot_0/gripper/fingers_actuator");
  EXPECT_EQ(mm->actuator_trntype[fingers], mjTRN_TENDON);
  EXPECT_EQ(mm->actuator_trnid[2 * fingers], Id(mm, mjOBJ_TENDON, "robot_0/gripper/split"));
  Id(mm, mjOBJ_SITE, "robot_0/gripper/grasp_site");
  Id(mm, mjOBJ_SITE, "robot_0/fr3_flange");
  Id(mm, mjOBJ_GEOM, "robot_0/gripper/left_pad2");
  Id(mm, mjOBJ_GEOM, "robot_0/gripper/right_pad2");
  const int cam = Id(mm, mjOBJ_CAMERA, "robot_0/gripper/wrist_camera");
  EXPECT_EQ(mm->cam_bodyid[cam], Id(mm, mjOBJ_BODY, "robot_0/gripper/base"));
  EXPECT_NEAR(mm->cam_fovy[cam], 56.74, 1e-9);
  EXPECT_EQ(mm->nu, 8);
  EXPECT_EQ(mm->neq, 3);
  // Every named element of the robot carries the prefix.
  for (int b = 1; b < mm->nbody; ++b) {
    EXPECT_EQ(std::string(mj_id2name(mm, mjOBJ_BODY, b)).rfind("robot_0/", 0), 0u);
  }
  // The home pose ships with the model as custom numerics.
  const int home = Id(mm, mjOBJ_NUMERIC, "robot_0/home_arm");
  ASSERT_EQ(mm->numeric_size[home], 7);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(mm->numeric_data[mm->numeric_adr[home] + i], kHomeArm[i]);
  const int home_g = Id(mm, mjOBJ_NUMERIC, "robot_0/home_gripper");
  ASSERT_EQ(mm->numeric_size[home_g], 2);
  EXPECT_EQ(mm->numeric_data[mm->numeric_adr[home_g]], kHomeGripper[0]);
}

TEST(FrankaDroid, JointRangesAndServosMatchTheSpec) {
  ModelPtr m = Compose(kBareScene);
  const Robot r(m.get());
  for (int i = 0; i < 7; ++i) {
    const int j = mj_name2id(m.get(), mjOBJ_JOINT, ArmJoint(i).c_str());
    EXPECT_TRUE(m->jnt_limited[j]);
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * j], kLower[i]) << ArmJoint(i);
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * j + 1], kUpper[i]) << ArmJoint(i);
    EXPECT_GT(kHomeArm[i], kLower[i]);
    EXPECT_LT(kHomeArm[i], kUpper[i]);
    const int a = r.arm_act[i];
    EXPECT_DOUBLE_EQ(m->actuator_ctrlrange[2 * a], kLower[i]);
    EXPECT_DOUBLE_EQ(m->actuator_ctrlrange[2 * a + 1], kUpper[i]);
    EXPECT_EQ(m->actuator_biastype[a], mjBIAS_AFFINE);
    EXPECT_DOUBLE_EQ(m->actuator_gainprm[mjNGAIN * a], kKp[i]);
    EXPECT_DOUBLE_EQ(m->actuator_biasprm[mjNBIAS * a + 1], -kKp[i]);
    EXPECT_DOUBLE_EQ(m->actuator_biasprm[mjNBIAS * a + 2], -kKp[i] / 10);
    EXPECT_DOUBLE_EQ(m->actuator_forcerange[2 * a + 1], i < 4 ? 87.0 : 12.0);
  }
  const int f = r.fingers;
  EXPECT_DOUBLE_EQ(m->actuator_ctrlrange[2 * f], 0);
  EXPECT_DOUBLE_EQ(m->actuator_ctrlrange[2 * f + 1], 255);
  EXPECT_NEAR(m->actuator_gainprm[mjNGAIN * f], 0.3137, 1e-4);
  EXPECT_DOUBLE_EQ(m->actuator_biasprm[mjNBIAS * f + 1], -100);
  EXPECT_DOUBLE_EQ(m->actuator_biasprm[mjNBIAS * f + 2], -10);
  EXPECT_DOUBLE_EQ(m->actuator_forcerange[2 * f + 1], 5);
  for (const char* name :
       {"robot_0/gripper/left_driver_joint", "robot_0/gripper/right_driver_joint"}) {
    const int j = mj_name2id(m.get(), mjOBJ_JOINT, name);
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * j], 0) << name;
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * j + 1], 0.9) << name;
  }
  EXPECT_EQ(m->opt.integrator, mjINT_IMPLICIT);
}

TEST(FrankaDroid, ForwardKinematicsMatchesTheDhTable) {
  Pose base;
  base.pos = {-0.4, 0.25, 0.1};
  base.quat = {std::cos(0.3), 0, 0, std::sin(0.3)};  // 0.6 rad about z
  ModelPtr m = Compose(kBareScene, base);
  DataPtr d = MakeData(m.get());
  const Robot r(m.get());
  std::mt19937 rng(7);
  for (int trial = 0; trial < 25; ++trial) {
    std::array<double, 7> q = kHomeArm;
    if (trial > 0) {
      for (int i = 0; i < 7; ++i) {
        q[i] = std::uniform_real_distribution<double>(kLower[i], kUpper[i])(rng);
      }
    }
    for (int i = 0; i < 7; ++i) d->qpos[r.arm_qpos[i]] = q[i];
    mj_kinematics(m.get(), d.get());
    const Mat4 flange = DhFlange(base, q);
    const Mat4 tcp = Mul(flange, Trans(0, 0, kTcpOffset));
    EXPECT_LT(MaxAbsDiff(SiteTransform(d.get(), r.flange), flange), 1e-9) << "trial " << trial;
    EXPECT_LT(MaxAbsDiff(SiteTransform(d.get(), r.tcp), tcp), 1e-9) << "trial " << trial;
    if (trial == 0) {
      // Known numbers of the home pose (base at the identity): flange at about
      // (0.307, 0, 0.590) pointing down, so the TCP sits 0.14 m below it.
      const Mat4 home = DhFlange(Pose{}, q);
      EXPECT_NEAR(home[3], 0.3069, 1e-3);
      EXPECT_NEAR(home[7], 0.0, 1e-3);
      EXPECT_NEAR(home[11], 0.5903, 1e-3);
      EXPECT_NEAR(home[10], -1.0, 1e-6);
    }
  }
  // The mocap base carries the arm: moving it moves the TCP rigidly.
  d->mocap_pos[3 * r.base_mocap + 2] += 0.2;
  mj_kinematics(m.get(), d.get());
  Pose raised = base;
  raised.pos[2] += 0.2;
  std::array<double, 7> q{};
  for (int i = 0; i < 7; ++i) q[i] = d->qpos[r.arm_qpos[i]];
  EXPECT_LT(MaxAbsDiff(SiteTransform(d.get(), r.flange), DhFlange(raised, q)), 1e-9);
}

TEST(FrankaDroid, TcpFrameApproachesAlongZWithFingersAlongY) {
  ModelPtr m = Compose(kBareScene);
  DataPtr d = MakeData(m.get());
  const Robot r(m.get());
  r.SetHome(d.get());
  mj_forward(m.get(), d.get());
  EXPECT_EQ(d->ncon, 0) << "no self-contacts at home";
  const Mat4 tcp = SiteTransform(d.get(), r.tcp);
  const Mat4 fl = SiteTransform(d.get(), r.flange);
  // +z of the TCP points away from the flange: TCP = flange + 0.14 z.
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(tcp[4 * c + 3] - fl[4 * c + 3], kTcpOffset * tcp[4 * c + 2], 1e-12);
  }
  // At home the TCP is the tutorial's top-down grasp frame: x=(1,0,0), y=(0,-1,0), z=(0,0,-1).
  EXPECT_NEAR(tcp[0], 1, 1e-6);
  EXPECT_NEAR(tcp[5], -1, 1e-6);
  EXPECT_NEAR(tcp[10], -1, 1e-6);
  // The pads face each other across the TCP along +-y (left = +y), centred on x and z.
  const auto left = r.InTcp(d.get(), d->geom_xpos + 3 * r.pad[0]);
  const auto right = r.InTcp(d.get(), d->geom_xpos + 3 * r.pad[1]);
  EXPECT_GT(left[1], 0.04);
  EXPECT_LT(right[1], -0.04);
  EXPECT_NEAR(left[0], 0, 1e-9);
  EXPECT_NEAR(right[0], 0, 1e-9);
  EXPECT_NEAR(left[2], 0, 0.006);
  EXPECT_NEAR(right[2], 0, 0.006);
  // The pads are parallel to the TCP frame.
  const mjtNum* pr = d->geom_xmat + 9 * r.pad[0];
  const mjtNum* tr = d->site_xmat + 9 * r.tcp;
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(pr[k], tr[k], 1e-2);
  // The wrist camera looks along the approach (camera forward = -z of the camera frame).
  const int cam = mj_name2id(m.get(), mjOBJ_CAMERA, "robot_0/gripper/wrist_camera");
  const mjtNum* cr = d->cam_xmat + 9 * cam;
  const double fwd_dot_z = -(cr[2] * tr[2] + cr[5] * tr[5] + cr[8] * tr[8]);
  EXPECT_GT(fwd_dot_z, 0.8);
}

TEST(FrankaDroid, GripperOpensTo85mmAndClosesFully) {
  ModelPtr m = Compose(kBareScene);
  DataPtr d = MakeData(m.get());
  const Robot r(m.get());
  r.SetHome(d.get(), 255);
  for (int s = 0; s < 500; ++s) r.Step(d.get());
  mj_forward(m.get(), d.get());
  const double closed = r.PadGap(d.get());
  EXPECT_LT(std::max(0.0, closed), 0.001) << "closed width at ctrl 255";
  EXPECT_GT(closed, -0.002) << "pads must not pass through each other";
  d->ctrl[r.fingers] = 0;
  for (int s = 0; s < 500; ++s) r.Step(d.get());
  mj_forward(m.get(), d.get());
  const double open = r.PadGap(d.get());
  EXPECT_NEAR(open, 0.085, 0.001) << "open width at ctrl 0";
  EXPECT_LE(open, 0.087);   // MolmoSpaces' inter_finger_dist_range upper end
  EXPECT_GT(open, 0.0435);  // its is_open threshold
  for (int k = 0; k < 2; ++k) EXPECT_NEAR(d->qpos[r.driver_qpos[k]], 0, 0.01);
}

// The robot's bodies: fr3_link0 and everything below it (arm and gripper).
std::vector<int> RobotBodies(const mjModel* m) {
  const int root = Id(m, mjOBJ_BODY, "robot_0/fr3_link0");
  std::vector<int> out;
  for (int b = 1; b < m->nbody; ++b) {
    int a = b;
    while (a > 0 && a != root) a = m->body_parentid[a];
    if (a == root) out.push_back(b);
  }
  return out;
}

TEST(FrankaDroid, GravcompOnEveryRobotBodyCancelsGravity) {
  ModelPtr m = Compose(kBareScene);
  DataPtr d = MakeData(m.get());
  const Robot r(m.get());
  const std::vector<int> bodies = RobotBodies(m.get());
  ASSERT_EQ(bodies.size(), 13u);  // fr3_link0..7 + gripper base, 2 drivers, 2 followers
  for (int b : bodies) EXPECT_EQ(m->body_gravcomp[b], 1) << MjName(m.get(), mjOBJ_BODY, b);
  EXPECT_EQ(m->body_gravcomp[Id(m.get(), mjOBJ_BODY, "robot_0/base")], 0);
  EXPECT_EQ(m->ngravcomp, 13);
  // At rest the bias is gravity alone; MuJoCo's gravcomp force cancels it on every robot dof.
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    for (int i = 0; i < 7; ++i) {
      d->qpos[r.arm_qpos[i]] = std::uniform_real_distribution<double>(kLower[i], kUpper[i])(rng);
    }
    for (int k = 0; k < 2; ++k) d->qpos[r.driver_qpos[k]] = 0.3 * trial / 4;
    mju_zero(d->qvel, m->nv);
    mj_forward(m.get(), d.get());
    double largest = 0;
    for (int v = 0; v < m->nv; ++v) {
      EXPECT_NEAR(d->qfrc_gravcomp[v], d->qfrc_bias[v], 1e-9) << v;
      largest = std::max(largest, std::abs(d->qfrc_bias[v]));
    }
    EXPECT_GT(largest, 1) << "gravity loads the arm";
  }
}

// Runs 2 s with the servos at home; returns {max joint error (rad), max TCP drift (m)}.
std::array<double, 2> HoldHome(const mjModel* model, bool gravcomp) {
  ModelPtr copy(mj_copyModel(nullptr, model));
  mjModel* m = copy.get();
  if (!gravcomp) {
    for (int b : RobotBodies(m)) m->body_gravcomp[b] = 0;
  }
  DataPtr d = MakeData(m);
  const Robot r(m);
  r.SetHome(d.get());
  mj_forward(m, d.get());
  const std::array<double, 3> start = {d->site_xpos[3 * r.tcp], d->site_xpos[3 * r.tcp + 1],
                                       d->site_xpos[3 * r.tcp + 2]};
  double joint_err = 0, drift = 0;
  for (int s = 0; s < 1000; ++s) {
    r.Step(d.get());
    mj_kinematics(m, d.get());
    for (int i = 0; i < 7; ++i) {
      joint_err = std::max(joint_err, std::abs(d->qpos[r.arm_qpos[i]] - kHomeArm[i]));
    }
    drift = std::max(drift, std::sqrt(std::pow(d->site_xpos[3 * r.tcp] - start[0], 2) +
                                      std::pow(d->site_xpos[3 * r.tcp + 1] - start[1], 2) +
                                      std::pow(d->site_xpos[3 * r.tcp + 2] - start[2], 2)));
  }
  return {joint_err, drift};
}

TEST(FrankaDroid, CompensatedArmHoldsItsHomePose) {
  ModelPtr m = Compose(kBareScene);
  const auto [err, drift] = HoldHome(m.get(), /*gravcomp=*/true);
  EXPECT_LT(err, 1e-3) << "rad";
  EXPECT_LT(drift, 1e-3) << "m";
  // Control: without compensation the same servos sag measurably, so the test can fail.
  const auto [err_off, drift_off] = HoldHome(m.get(), /*gravcomp=*/false);
  EXPECT_GT(err_off, 2 * err);
  EXPECT_GT(err_off, 1e-3) << "rad";
  EXPECT_GT(drift_off, drift);
}

TEST(FrankaDroid, AloneItHasTheOriginalsOptionsAndHoldsItsHomePose) {
  // The robot file alone: menagerie FR3's implicitfast, the 2F-85's elliptic cone and
  // impratio 10. Attached into a scene, the scene's <option> rules (kBareScene: implicit).
  ModelPtr alone = MjcfComposer(kRobot).Compile();
  EXPECT_EQ(alone->opt.integrator, mjINT_IMPLICITFAST);
  EXPECT_EQ(alone->opt.cone, mjCONE_ELLIPTIC);
  EXPECT_EQ(alone->opt.impratio, 10);
  ModelPtr attached = Compose(kBareScene);
  EXPECT_EQ(attached->opt.integrator, mjINT_IMPLICIT);
  // The attached robot with the robot file's own options holds its home pose too.
  mjModel* m = attached.get();
  m->opt.integrator = mjINT_IMPLICITFAST;
  m->opt.cone = mjCONE_ELLIPTIC;
  m->opt.impratio = 10;
  const auto [err, drift] = HoldHome(m, /*gravcomp=*/true);
  EXPECT_LT(err, 1e-3) << "rad";
  EXPECT_LT(drift, 1e-3) << "m";
}

bool Touches(const mjModel*, const mjData* d, int geom_a, int geom_b) {
  for (int c = 0; c < d->ncon; ++c) {
    const int g1 = d->contact[c].geom1, g2 = d->contact[c].geom2;
    if ((g1 == geom_a && g2 == geom_b) || (g1 == geom_b && g2 == geom_a)) return true;
  }
  return false;
}

// Arm joints that raise the TCP by `dz` keeping its orientation: damped least squares on the
// 6x7 site Jacobian, on a scratch mjData.
std::array<double, 7> LiftIk(const mjModel* m, const Robot& r, std::array<double, 7> q, double dz) {
  DataPtr d = MakeData(m);
  auto set = [&] {
    for (int i = 0; i < 7; ++i) d->qpos[r.arm_qpos[i]] = q[i];
    mj_kinematics(m, d.get());
    mj_comPos(m, d.get());
  };
  set();
  std::array<double, 3> target = {d->site_xpos[3 * r.tcp], d->site_xpos[3 * r.tcp + 1],
                                  d->site_xpos[3 * r.tcp + 2] + dz};
  std::array<double, 9> rot{};
  std::copy(d->site_xmat + 9 * r.tcp, d->site_xmat + 9 * r.tcp + 9, rot.begin());
  std::vector<mjtNum> jacp(3 * m->nv), jacr(3 * m->nv);
  for (int iter = 0; iter < 50; ++iter) {
    set();
    double err[6];
    for (int c = 0; c < 3; ++c) err[c] = target[c] - d->site_xpos[3 * r.tcp + c];
    // Orientation error: 0.5 * sum_k cur_k x goal_k over the frame's columns.
    const mjtNum* cur = d->site_xmat + 9 * r.tcp;
    for (int c = 0; c < 3; ++c) err[3 + c] = 0;
    for (int k = 0; k < 3; ++k) {
      const double a[3] = {cur[k], cur[3 + k], cur[6 + k]};
      const double b[3] = {rot[k], rot[3 + k], rot[6 + k]};
      err[3] += 0.5 * (a[1] * b[2] - a[2] * b[1]);
      err[4] += 0.5 * (a[2] * b[0] - a[0] * b[2]);
      err[5] += 0.5 * (a[0] * b[1] - a[1] * b[0]);
    }
    mj_jacSite(m, d.get(), jacp.data(), jacr.data(), r.tcp);
    double jac[6][7];
    for (int row = 0; row < 3; ++row) {
      for (int i = 0; i < 7; ++i) {
        jac[row][i] = jacp[row * m->nv + r.arm_dof[i]];
        jac[row + 3][i] = jacr[row * m->nv + r.arm_dof[i]];
      }
    }
    // dq = J^T (J J^T + lambda I)^-1 err, solved by Gaussian elimination.
    double a[6][7];
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j < 6; ++j) {
        a[i][j] = i == j ? 1e-6 : 0;
        for (int k = 0; k < 7; ++k) a[i][j] += jac[i][k] * jac[j][k];
      }
      a[i][6] = err[i];
    }
    for (int i = 0; i < 6; ++i) {
      for (int k = i + 1; k < 6; ++k) {
        const double f = a[k][i] / a[i][i];
        for (int j = i; j < 7; ++j) a[k][j] -= f * a[i][j];
      }
    }
    double y[6];
    for (int i = 5; i >= 0; --i) {
      y[i] = a[i][6];
      for (int j = i + 1; j < 6; ++j) y[i] -= a[i][j] * y[j];
      y[i] /= a[i][i];
    }
    for (int k = 0; k < 7; ++k) {
      for (int i = 0; i < 6; ++i) q[k] += jac[i][k] * y[i];
    }
  }
  set();
  EXPECT_NEAR(d->site_xpos[3 * r.tcp + 2], target[2], 1e-6) << "lift IK";
  return q;
}

// Grasps a 5 cm, 0.125 kg block off a table at the home pose, lifts it 10 cm with the arm and
// holds it 2 s. `contact_options` go on the scene's <option>. Returns the block's slip in the
// TCP frame over the hold (m) and over its first and second second along z.
struct GraspResult {
  double slip = 0, first = 0, second = 0;
};

GraspResult GraspAndLift(const std::string& contact_options) {
  GraspResult result;
  // Table top 2.5 cm below the home TCP, block centred on the TCP.
  const Mat4 home = Mul(DhFlange(Pose{}, kHomeArm), Trans(0, 0, kTcpOffset));
  const double top = home[11] - 0.025;
  const std::string scene =
      R"(<mujoco model="grasp_test">
  <option timestep="0.002" integrator="implicit" )" +
      contact_options + R"(/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="table" pos=")" +
      std::to_string(home[3]) + " 0 " + std::to_string(top / 2) + R"(">
      <geom name="table_top" type="box" size="0.1 0.1 )" +
      std::to_string(top / 2) + R"("/>
    </body>
    <body name="block" pos=")" +
      std::to_string(home[3]) + " " + std::to_string(home[7]) + " " + std::to_string(top + 0.025) +
      R"(">
      <freejoint/>
      <geom name="block_geom" type="box" size="0.025 0.025 0.025" mass="0.125"/>
    </body>
  </worldbody>
</mujoco>)";
  ModelPtr m = Compose(scene);
  DataPtr d = MakeData(m.get());
  const Robot r(m.get());
  const int block = mj_name2id(m.get(), mjOBJ_BODY, "block");
  const int table_geom = mj_name2id(m.get(), mjOBJ_GEOM, "table_top");
  const int block_geom = mj_name2id(m.get(), mjOBJ_GEOM, "block_geom");
  r.SetHome(d.get(), 0);
  for (int s = 0; s < 150; ++s) r.Step(d.get());  // settle open
  d->ctrl[r.fingers] = 255;
  for (int s = 0; s < 400; ++s) r.Step(d.get());  // close
  mj_forward(m.get(), d.get());
  EXPECT_TRUE(Touches(m.get(), d.get(), r.pad[0], block_geom)) << "left pad on the block";
  EXPECT_TRUE(Touches(m.get(), d.get(), r.pad[1], block_geom)) << "right pad on the block";
  EXPECT_NEAR(r.PadGap(d.get()), 0.05, 0.006) << "pads squeeze the block";
  const double z0 = d->xpos[3 * block + 2];
  // Lift the TCP 10 cm with the arm joints (as the pick planner does; moving the mocap base
  // would teleport the pads without a velocity, which friction cannot follow) in 0.8 s.
  std::array<double, 7> q0{};
  for (int i = 0; i < 7; ++i) q0[i] = d->ctrl[r.arm_act[i]];
  const std::array<double, 7> q1 = LiftIk(m.get(), r, q0, 0.1);
  for (int s = 1; s <= 400; ++s) {
    const double t = s / 400.0, blend = t * t * (3 - 2 * t);
    for (int i = 0; i < 7; ++i) d->ctrl[r.arm_act[i]] = q0[i] + blend * (q1[i] - q0[i]);
    r.Step(d.get());
  }
  for (int s = 0; s < 100; ++s) r.Step(d.get());  // settle
  mj_forward(m.get(), d.get());
  const auto lifted = r.InTcp(d.get(), d->xpos + 3 * block);
  for (int s = 0; s < 500; ++s) r.Step(d.get());  // hold 2 s
  mj_forward(m.get(), d.get());
  const auto mid = r.InTcp(d.get(), d->xpos + 3 * block);
  for (int s = 0; s < 500; ++s) r.Step(d.get());
  mj_forward(m.get(), d.get());
  const auto held = r.InTcp(d.get(), d->xpos + 3 * block);
  EXPECT_GT(d->xpos[3 * block + 2] - z0, 0.095) << "block lifted with the gripper";
  double slip = 0;
  for (int c = 0; c < 3; ++c) slip += (held[c] - lifted[c]) * (held[c] - lifted[c]);
  result.slip = std::sqrt(slip);
  result.first = std::abs(mid[2] - lifted[2]);
  result.second = std::abs(held[2] - mid[2]);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(held[c], 0, 0.01) << "block stays at the TCP";
  // Held by both pads, off the table.
  EXPECT_TRUE(Touches(m.get(), d.get(), r.pad[0], block_geom));
  EXPECT_TRUE(Touches(m.get(), d.get(), r.pad[1], block_geom));
  EXPECT_FALSE(Touches(m.get(), d.get(), table_geom, block_geom));
  return result;
}

TEST(FrankaDroid, HoldsA5cmBlockWhileLifting) {
  // MuJoCo's defaults (pyramidal cone, impratio 1): soft-contact creep of under 1 mm/s.
  const GraspResult plain = GraspAndLift("");
  EXPECT_LT(plain.slip, 0.003) << "m over 2 s";
  // Elliptic cone with impratio 10 (what a grasping scene should use): the grasp settles.
  const GraspResult stiff = GraspAndLift(R"(cone="elliptic" impratio="10")");
  EXPECT_LT(stiff.slip, 0.0005) << "m over 2 s";
  EXPECT_LT(stiff.second, stiff.first) << "creep must die out";
  EXPECT_LT(stiff.second, 1e-4) << "m in the second second";
}

}  // namespace
}  // namespace mlspaces::sim
