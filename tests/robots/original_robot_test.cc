// robot_config.robot_files: molmospaces: franka_droid with MolmoSpaces' own robot files, found
// where `mlspaces install` puts them (<assets>/robots/franka_droid/, spec 2.3) and described by
// assets/robots/franka_droid/molmospaces.yaml. The real files (meshes) are not in the test: it
// writes a folder in their layout whose model.xml has the original's structure and names
// (menagerie's FR3 with its static `base` wrapper and `fr3_link0_collision` geom, a 2F-85
// four-bar linkage under `gripper/`: driver, coupler, spring link and follower joints closed
// by equality constraints, the split tendon, grasp site and wrist camera), primitive geoms
// standing in for the meshes. model.xml is a link into a cache folder, as an install leaves it.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/camera_recorder.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_runner.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/robots/ik.h"
#include "mlspaces/robots/robot_view.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string Vec(double x, double y, double z) { return Num(x) + " " + Num(y) + " " + Num(z); }

// Franka's published modified-DH table (a, d, alpha) of joints 1-7: body i sits at
// (a, -d sin alpha, d cos alpha), rotated by alpha about x, in body i - 1.
struct Dh {
  double a, d, alpha;
};
constexpr double kPi = 3.14159265358979323846;
const Dh kDh[7] = {{0, 0.333, 0},        {0, 0, -kPi / 2},           {0, 0.316, kPi / 2},
                   {0.0825, 0, kPi / 2}, {-0.0825, 0.384, -kPi / 2}, {0, 0, kPi / 2},
                   {0.088, 0, kPi / 2}};
const char* kRange[7] = {"-2.9007 2.9007", "-1.8361 1.8361", "-2.9007 2.9007", "-3.0770 -0.1169",
                         "-2.8763 2.8763", "0.4398 4.6216",  "-3.0508 3.0508"};
const double kKp[7] = {4500, 4500, 3500, 3500, 2000, 2000, 2000};
const double kMass[8] = {2.9, 4.97, 0.65, 3.23, 3.59, 1.23, 1.67, 0.74};

// Formats `text`, replacing each '%' with the next value of `args`.
std::string Fill(std::string_view text, std::initializer_list<std::string> args) {
  std::string out;
  auto arg = args.begin();
  for (char c : text) {
    if (c == '%' && arg != args.end()) {
      out += *arg++;
    } else {
      out += c;
    }
  }
  return out;
}

// One finger of the four-bar gripper. side +1: left (+y), -1: right. The driver and the spring
// link are equal cranks (0.0546 m, tilted 0.4 rad outward when open) on pivots 18 mm apart in
// y and 15 mm in z; the follower rides on the spring link and is tied to the driver's coupler
// by a connect equality, so the pad stays parallel: 85 mm apart open, touching near 0.8 rad.
std::string Finger(const std::string& s, int side) {
  const double tilt = 0.4;
  const std::string out_quat = Vec(std::cos(tilt / 2), -side * std::sin(tilt / 2), 0) + " 0";
  const std::string back_quat = Vec(std::cos(tilt / 2), side * std::sin(tilt / 2), 0) + " 0";
  const std::string axis = side > 0 ? "1 0 0" : "-1 0 0";
  return Fill(R"xml(
<body name="gripper/%_driver" pos="%" quat="%">
  <joint name="gripper/%_driver_joint" axis="%" range="0 0.9" armature="0.005" damping="0.1"/>
  <geom class="link" fromto="0 0 0 0 0 0.0546" mass="0.02"/>
  <body name="gripper/%_coupler" pos="0 0 0.0546"><geom class="link" size="0.004" mass="0.01"
    type="sphere"/></body>
</body>
<body name="gripper/%_spring_link" pos="%" quat="%">
  <joint name="gripper/%_spring_link_joint" class="passive" axis="%" range="-0.5 1.2"/>
  <geom class="link" fromto="0 0 0 0 0 0.0546" mass="0.02"/>
  <body name="gripper/%_follower" pos="0 0 0.0546" quat="%">
    <joint name="gripper/%_follower_joint" class="passive" axis="%" range="-1.2 0.5"/>
    <geom class="link" fromto="0 0 0 0 % -0.015" mass="0.01"/>
    <body name="gripper/%_pad" pos="%">
      <geom name="gripper/%_pad1" class="pad" pos="0 0 -0.009"/>
      <geom name="gripper/%_pad2" class="pad" pos="0 0 0.009"/>
    </body>
  </body>
</body>)xml",
              {s,         Vec(0, side * 0.030, 0.060),
               out_quat,  s,
               axis,      s,
               s,         Vec(0, side * 0.012, 0.075),
               out_quat,  s,
               axis,      s,
               back_quat, s,
               axis,      Num(side * 0.018),
               s,         Vec(0, side * 0.01324, 0.01471),
               s,         s});
}

// model.xml in the original's structure (FrankaRobot inserts fr3_link0's subtree only).
std::string OriginalLayoutModel() {
  std::string xml = Fill(R"xml(<mujoco model="fr3_robotiq_2f85 (test stand-in)">
  <compiler angle="radian" autolimits="true"/>
  <option integrator="implicitfast" cone="elliptic" impratio="10"/>
  <default>
    <default class="fr3">
      <joint armature="0.1" damping="1"/>
      <geom contype="2" conaffinity="1" rgba="0.9 0.9 0.9 1"/>
      <default class="passive"><joint armature="0.001" damping="0.001"/></default>
      <default class="link"><geom type="capsule" size="0.004" contype="0" conaffinity="0"
        group="2"/></default>
      <default class="pad">
        <geom type="box" size="0.011 0.004 0.009" mass="0.005" contype="4" conaffinity="5"
              friction="1 0.005 0.0001" condim="4" solimp="0.95 0.99 0.001" rgba="0.2 0.2 0.2 1"/>
      </default>
    </default>
  </default>
  <worldbody>
    <body name="base" childclass="fr3">
      <body name="fr3_link0">
        <geom name="fr3_link0_collision" type="cylinder" size="0.06 0.05" pos="0 0 0.05"
              mass="%"/>
)xml",
                         {Num(kMass[0])});
  std::string close;
  for (int i = 0; i < 7; ++i) {
    const Dh& dh = kDh[i];
    const Dh* next = i < 6 ? &kDh[i + 1] : nullptr;
    const std::string n = std::to_string(i + 1);
    xml += "<body name=\"fr3_link" + n + "\" pos=\"" +
           Vec(dh.a, -dh.d * std::sin(dh.alpha), dh.d * std::cos(dh.alpha)) + "\" quat=\"" +
           Vec(std::cos(dh.alpha / 2), std::sin(dh.alpha / 2), 0) + " 0\">\n" +
           "<joint name=\"fr3_joint" + n + "\" axis=\"0 0 1\" range=\"" + kRange[i] + "\"/>\n";
    // A capsule to the next joint (or the flange), a sphere where they coincide.
    const double to[3] = {next ? next->a : 0, next ? -next->d * std::sin(next->alpha) : 0,
                          next ? next->d * std::cos(next->alpha) : 0.107};
    const double len = std::sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
    xml += len < 1e-9
               ? "<geom type=\"sphere\" size=\"0.055\" mass=\"" + Num(kMass[i + 1]) + "\"/>\n"
               : "<geom type=\"capsule\" size=\"0.045\" fromto=\"0 0 0 " +
                     Vec(to[0], to[1], to[2]) + "\" mass=\"" + Num(kMass[i + 1]) + "\"/>\n";
    close += "</body>\n";
  }
  xml += R"xml(<body name="gripper/base" pos="0 0 0.107">
  <geom name="gripper/palm" type="box" size="0.03 0.045 0.03" pos="0 0 0.03" mass="0.78"/>
  <site name="gripper/grasp_site" pos="0 0 0.14"/>
  <camera name="gripper/wrist_camera" pos="-0.07 0 0.03" xyaxes="0 -1 0 -1 0 0" fovy="56.74"/>
)xml" + Finger("left", 1) +
         Finger("right", -1) + "</body>\n" + close + R"xml(      </body>
    </body>
  </worldbody>
  <contact><exclude body1="fr3_link0" body2="fr3_link1"/></contact>
  <tendon>
    <fixed name="gripper/split">
      <joint joint="gripper/right_driver_joint" coef="0.485"/>
      <joint joint="gripper/left_driver_joint" coef="0.485"/>
    </fixed>
  </tendon>
  <equality>
    <connect body1="gripper/left_follower" body2="gripper/left_coupler" anchor="0 0.018 -0.015"
             solref="0.005 1" solimp="0.95 0.99 0.001"/>
    <connect body1="gripper/right_follower" body2="gripper/right_coupler" anchor="0 -0.018 -0.015"
             solref="0.005 1" solimp="0.95 0.99 0.001"/>
    <joint joint1="gripper/right_driver_joint" joint2="gripper/left_driver_joint"
           polycoef="0 1 0 0 0" solref="0.005 1" solimp="0.95 0.99 0.001"/>
  </equality>
  <actuator>
)xml";
  for (int i = 0; i < 7; ++i) {
    const std::string n = std::to_string(i + 1);
    xml += "    <position name=\"fr3_joint" + n + "\" joint=\"fr3_joint" + n + "\" kp=\"" +
           Num(kKp[i]) + "\" kv=\"" + Num(kKp[i] / 10) + "\" ctrlrange=\"" + kRange[i] +
           "\" forcerange=\"" + (i < 4 ? "-87 87" : "-12 12") + "\"/>\n";
  }
  xml += R"xml(    <general name="gripper/fingers_actuator" tendon="gripper/split" forcerange="-5 5"
             ctrlrange="0 255" gainprm="0.3137255 0 0" biasprm="0 -100 -10" biastype="affine"/>
  </actuator>
</mujoco>
)xml";
  return xml;
}

// <root>/assets/robots/franka_droid/model.xml -> <root>/cache/robots/franka_droid/<v>/model.xml
struct InstalledRobot {
  InstalledRobot() {
    const fs::path cache = tmp / "cache/robots/franka_droid/20260127";
    fs::create_directories(cache);
    fs::create_directories(assets / "robots/franka_droid");
    std::ofstream(cache / "model.xml") << OriginalLayoutModel();
    fs::create_symlink(cache / "model.xml", assets / "robots/franka_droid/model.xml");
  }
  testing::TempDir tmp;
  fs::path assets = tmp / "assets";
};

RobotConfig Original() {
  RobotConfig c;
  c.robot_files = RobotFiles::kMolmoSpaces;
  c.base_size.reset();
  return c;
}

TEST(OriginalRobotTest, UsesTheInstalledModelWithTheOriginalsNames) {
  InstalledRobot installed;
  const RobotSpec spec = RobotSpecFromConfig(Original(), {}, installed.assets);
  EXPECT_EQ(spec.xml, fs::absolute(installed.assets / "robots/franka_droid/model.xml"));
  EXPECT_EQ(spec.description_file.filename(), "molmospaces.yaml");
  EXPECT_EQ(spec.name, "franka_droid");
  EXPECT_EQ(spec.articulation_name, "panda");
  EXPECT_TRUE(spec.mirrored_joints.empty());
  const RobotSpec bundled = RobotSpecFromConfig(RobotConfig{});
  EXPECT_NE(spec.description_hash, bundled.description_hash);
  EXPECT_EQ(spec.home_arm, bundled.home_arm);
  EXPECT_EQ(spec.articulation_width, bundled.articulation_width);

  Env env = Env::Create(sim::Scene::Load(kExample / "scene.xml"), spec, "house_0");
  const mjModel* m = env.model();
  // The installed model's own geom, inserted under the prefix; our bundled model has none.
  EXPECT_GE(mj_name2id(m, mjOBJ_GEOM, "robot_0/fr3_link0_collision"), 0);
  const Env ours = Env::Create(sim::Scene::Load(kExample / "scene.xml"), bundled, "house_0");
  EXPECT_LT(mj_name2id(ours.model(), mjOBJ_GEOM, "robot_0/fr3_link0_collision"), 0);
  EXPECT_GE(mj_name2id(m, mjOBJ_JOINT, "robot_0/gripper/left_spring_link_joint"), 0);
  // The base is mlspaces' mocap body; the file's static `base` wrapper stays out.
  const int base = mj_name2id(m, mjOBJ_BODY, "robot_0/base");
  ASSERT_GE(base, 0);
  EXPECT_GE(m->body_mocapid[base], 0);
  EXPECT_EQ(m->body_parentid[mj_name2id(m, mjOBJ_BODY, "robot_0/fr3_link0")], base);
  // Gravity compensation reaches the gripper's linkage.
  EXPECT_EQ(m->body_gravcomp[mj_name2id(m, mjOBJ_BODY, "robot_0/gripper/left_follower")], 1);

  // The DROID camera config (written for the original) finds its cameras on this model.
  const CameraSystemConfig cameras = CamerasForRobot(CameraSystemConfig{}, env.robot());
  ASSERT_EQ(cameras.cameras.size(), 2u);
  EXPECT_EQ(cameras.cameras[0].mjcf_name, "gripper/wrist_camera");
  EXPECT_GE(mj_name2id(m, mjOBJ_CAMERA,
                       (cameras.cameras[0].robot_namespace + cameras.cameras[0].mjcf_name).c_str()),
            0);

  env.Reset();
  const robots::RobotView robot(m, env.robot());
  mjData* d = env.data();
  EXPECT_EQ(robot.ArmQpos(d),
            std::vector<double>(env.home_qpos().begin(), env.home_qpos().begin() + 7));
  EXPECT_NEAR(robot.InterFingerDistance(d), 0.085, 0.002);
  // The TCP points down at home (+z approach), fingers along the world y axis.
  const Mat4 tcp = robot.TcpPose(d);
  EXPECT_LT(tcp(2, 2), -0.99);
  EXPECT_GT(std::abs(tcp(1, 1)), 0.99);

  // IK to a pose 5 cm away, then the servos track it.
  const std::vector<std::string>& joints = robot.arm_joint_names();
  robots::IkSolver ik(m, "robot_0/gripper/grasp_site", joints, robot.ArmQpos(d));
  ik.SyncState(d);
  Mat4 target = tcp;
  target(0, 3) += 0.05;
  target(1, 3) -= 0.05;
  target(2, 3) -= 0.05;
  const robots::IkResult r = ik.Solve(target, robot.ArmQpos(d));
  ASSERT_TRUE(r.success);
  robot.SetArmTargets(d, r.q);
  robot.Step(d, 1000);
  mj_forward(m, d);
  const Mat4 reached = robot.TcpPose(d);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(reached(k, 3), target(k, 3), 0.003) << k;

  // The linkage closes: ctrl 255 brings the pads together, ctrl 0 opens them again.
  robot.SetGripperCtrl(d, 255);
  robot.Step(d, 500);
  mj_forward(m, d);
  EXPECT_LT(robot.InterFingerDistance(d), 0.002);
  robot.SetGripperCtrl(d, 0);
  robot.Step(d, 500);
  mj_forward(m, d);
  EXPECT_NEAR(robot.InterFingerDistance(d), 0.085, 0.002);
}

TEST(OriginalRobotTest, TutorialPickEpisodeSucceedsWithTheInstalledModel) {
  InstalledRobot installed;
  ExperimentConfig config =
      LoadConfigFile(kExample / "datagen.yaml", ConfigRegistry::WithBuiltins());
  ApplyOverride(config, "robot_config.robot_files=molmospaces", {});
  config.libraries.assets_dir = installed.assets;
  Env env = Env::Create(sim::Scene::Load(kExample / "scene.xml"),
                        RobotSpecFromConfig(config.robot_config, {}, config.libraries.assets_dir),
                        "house_0");
  ASSERT_GE(mj_name2id(env.model(), mjOBJ_GEOM, "robot_0/fr3_link0_collision"), 0);
  Registry registry;
  config.libraries.ApplyTo(registry);
  const std::unique_ptr<TaskSampler> sampler =
      TaskSamplerRegistry::WithBuiltins().Create(config, 3);
  EpisodeRunner runner(env, *sampler, registry, config);
  const EpisodeResult r = runner.Run(0);
  EXPECT_TRUE(r.success) << r.attempt.message;
  EXPECT_GE(r.attempt.extra["lift"].get<double>(), 0.06);
}

TEST(OriginalRobotTest, NotInstalledIsOneLineNamingTheKeyWhereAndTheInstallCommand) {
  testing::TempDir empty;
  testing::ExpectError([&] { RobotSpecFromConfig(Original(), {}, empty.path()); },
                       {"robot_config.robot_files", "not installed",
                        (fs::absolute(empty.path()) / "robots/franka_droid").string(),
                        "libraries.assets_dir", "mlspaces install --library robots/franka_droid"});
  // Without libraries.assets_dir: MLSPACES_ASSETS_DIR, as every other lookup.
  const char* kept = std::getenv("MLSPACES_ASSETS_DIR");
  const std::string before = kept ? kept : "";
  ::setenv("MLSPACES_ASSETS_DIR", empty.path().c_str(), 1);
  testing::ExpectError([&] { RobotSpecFromConfig(Original()); },
                       {"robot_config.robot_files", "MLSPACES_ASSETS_DIR"});
  if (kept) {
    ::setenv("MLSPACES_ASSETS_DIR", before.c_str(), 1);
  } else {
    ::unsetenv("MLSPACES_ASSETS_DIR");
  }
  // Only robots we ship a description of the original's files for.
  RobotConfig other = Original();
  other.name = "xarm7";
  testing::ExpectError([&] { RobotSpecFromConfig(other, {}, empty.path()); },
                       {"robot_config.robot_files", "robots that have one: franka_droid"});
  RobotConfig by_dir = Original();
  by_dir.robot_dir = empty.path();
  testing::ExpectError([&] { RobotSpecFromConfig(by_dir, {}, empty.path()); },
                       {"robot_config.robot_files", "robot_dir"});
  // The key is strict like every other.
  ExperimentConfig config;
  testing::ExpectError([&] { ApplyOverride(config, "robot_config.robot_files=molmo", {}); },
                       {"robot_config.robot_files", "bundled", "molmospaces"});
  // Bundled stays the default.
  EXPECT_EQ(RobotConfig{}.robot_files, RobotFiles::kBundled);
  EXPECT_EQ(RobotSpecFromConfig(RobotConfig{}).description_file.filename(), "robot.yaml");
}

}  // namespace
}  // namespace mlspaces::datagen
