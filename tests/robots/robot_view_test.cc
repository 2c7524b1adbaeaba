#include "mlspaces/robots/robot_view.h"

#include <cmath>
#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

using robots::RobotView;

const std::filesystem::path kScene =
    std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "scene.xml";

class RobotViewTest : public ::testing::Test {
 protected:
  RobotViewTest()
      : env_(Env::Load(kScene, FrankaDroidSpec(MLSPACES_SOURCE_DIR))),
        robot_(env_.model(), env_.robot()) {}
  Env env_;
  RobotView robot_;
};

TEST_F(RobotViewTest, ReadsTheHomePoseAndTheOpenGripper) {
  ASSERT_EQ(robot_.num_arm(), 7u);
  ASSERT_EQ(robot_.num_gripper(), 2u);
  const std::vector<double> q = robot_.ArmQpos(env_.data());
  for (size_t i = 0; i < 7; ++i) EXPECT_EQ(q[i], env_.home_qpos()[i]);
  EXPECT_EQ(robot_.ArmTargets(env_.data()), q);
  EXPECT_EQ(robot_.GripperQpos(env_.data())[0], 0.00296);
  // Open: the pads are about 85 mm apart (the 2F-85's stroke).
  EXPECT_NEAR(robot_.InterFingerDistance(env_.data()), 0.085, 0.003);
  EXPECT_EQ(robot_.arm_joint_names()[0], "robot_0/fr3_joint1");
  EXPECT_NEAR(robot_.arm_lower()[3], -3.0770, 1e-4);
}

TEST_F(RobotViewTest, ClosingTheGripperClosesTheGap) {
  mjData* d = env_.data();
  robot_.SetGripperCtrl(d, 1000.0);  // clipped to 255
  EXPECT_EQ(robot_.GripperCtrl(d), 255.0);
  robot_.Step(d, 500);
  mj_forward(env_.model(), d);
  EXPECT_LT(robot_.InterFingerDistance(d), 0.002);
}

TEST_F(RobotViewTest, ArmTargetsAreClippedToTheServoRange) {
  mjData* d = env_.data();
  std::vector<double> q(7, 100.0);
  robot_.SetArmTargets(d, q);
  for (double v : robot_.ArmTargets(d)) EXPECT_LT(v, 5.0);
  EXPECT_THROW(robot_.SetArmTargets(d, std::vector<double>(3, 0.0)), Error);
}

TEST_F(RobotViewTest, JacobianMatchesFiniteDifferences) {
  const mjModel* m = env_.model();
  mjData* d = env_.data();
  mj_forward(m, d);
  const std::vector<double> jac = robot_.ArmJacobian(d);
  const Mat4 base = robot_.TcpPose(d);
  const double h = 1e-6;
  for (size_t i = 0; i < 7; ++i) {
    const int adr = robot_.arm_qpos_adr()[i];
    const double keep = d->qpos[adr];
    d->qpos[adr] = keep + h;
    mj_kinematics(m, d);
    const Mat4 moved = robot_.TcpPose(d);
    d->qpos[adr] = keep;
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR((moved(r, 3) - base(r, 3)) / h, jac[r * 7 + i], 1e-4) << "joint " << i;
    }
  }
  mj_forward(m, d);
}

TEST_F(RobotViewTest, GripperGeomsAreTheGripperSubtree) {
  const mjModel* m = env_.model();
  int gripper = 0;
  for (int g = 0; g < m->ngeom; ++g) gripper += robot_.IsGripperGeom(g) ? 1 : 0;
  EXPECT_GT(gripper, 4);
  EXPECT_TRUE(robot_.IsGripperGeom(mj_name2id(m, mjOBJ_GEOM, "robot_0/gripper/left_pad2")));
  EXPECT_FALSE(robot_.IsGripperGeom(mj_name2id(m, mjOBJ_GEOM, "red_block_geom")));
  EXPECT_FALSE(robot_.IsGripperGeom(-1));
}

TEST(RobotViewErrors, MissingElementsAreNamed) {
  Env env = Env::Load(kScene, FrankaDroidSpec(MLSPACES_SOURCE_DIR));
  RobotSpec spec = env.robot();
  spec.tcp_site = "gripper/nope";
  testing::ExpectError([&] { RobotView(env.model(), spec); }, {"TCP site", "robot_0/gripper/nope"});
  spec = env.robot();
  spec.finger_pads[1] = "gripper/missing_pad";
  testing::ExpectError([&] { RobotView(env.model(), spec); }, {"finger pad", "missing_pad"});
}

TEST(RobotSpecFromConfigTest, ResolvesTheBundledRobotAndChecksTheName) {
  RobotConfig config;
  const RobotSpec spec = RobotSpecFromConfig(config);
  EXPECT_TRUE(std::filesystem::is_regular_file(spec.xml));
  EXPECT_EQ(spec.prefix, "robot_0/");
  EXPECT_EQ(spec.home_arm.size(), 7u);
  EXPECT_EQ(spec.home_arm[3], -2.35619);  // robot.yaml's, as FrankaRobotConfig's init_qpos
  EXPECT_EQ(spec.home_noise[6], 0.175);
  config.init_qpos.arm = {0, 1};
  testing::ExpectError([&] { RobotSpecFromConfig(config); },
                       {"robot_config.init_qpos.arm", "2 values, robot has 7 arm joints"});
  config.init_qpos.arm = {0, 0, 0, -2, 0, 2, 0.5};
  config.init_qpos_noise_range.arm = {0, 0, 0, 0, 0, 0, 0};
  const RobotSpec custom = RobotSpecFromConfig(config);
  EXPECT_EQ(custom.home_arm, config.init_qpos.arm);
  EXPECT_EQ(custom.home_noise, config.init_qpos_noise_range.arm);
  config = RobotConfig{};
  config.name = "ur5";
  testing::ExpectError([&] { RobotSpecFromConfig(config); }, {"robot_config.name", "ur5"});
  config.name = "franka_droid";
  config.robot_xml_path = "/no/such/robot.xml";
  testing::ExpectError([&] { RobotSpecFromConfig(config); },
                       {"/no/such/robot.xml", "robot_config.robot_xml_path"});
}

}  // namespace
}  // namespace mlspaces::datagen
