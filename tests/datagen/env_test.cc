#include "mlspaces/datagen/env.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

const std::filesystem::path kScene =
    std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "scene.xml";

Pose Base() {
  Pose base;
  base.pos = {0.1, -0.2, 0.0};
  base.quat = {std::cos(0.25), 0, 0, std::sin(0.25)};
  return base;
}

class EnvTest : public ::testing::Test {
 protected:
  EnvTest() : env_(Env::Load(kScene, FrankaDroidSpec(MLSPACES_SOURCE_DIR, Base()))) {}
  double Qpos(const std::string& joint) const {
    const int j = mj_name2id(env_.model(), mjOBJ_JOINT, joint.c_str());
    EXPECT_GE(j, 0) << joint;
    return env_.data()->qpos[env_.model()->jnt_qposadr[j]];
  }
  Env env_;
};

TEST_F(EnvTest, ComposedSceneHasRobotAndObjectAtHome) {
  EXPECT_EQ(env_.robot_base_body(), "robot_0/base");
  EXPECT_TRUE(env_.IsMovable("robot_0/base"));
  EXPECT_TRUE(env_.IsMovable("red_block"));
  EXPECT_FALSE(env_.IsMovable("robot_0/fr3_link3"));
  const double home[7] = {0, -0.7853, 0, -2.35619, 0, 1.57079, 0};
  for (int i = 0; i < 7; ++i) {
    const std::string joint = "robot_0/fr3_joint" + std::to_string(i + 1);
    EXPECT_EQ(Qpos(joint), home[i]) << joint;
    const int act = mj_name2id(env_.model(), mjOBJ_ACTUATOR, joint.c_str());
    EXPECT_EQ(env_.data()->ctrl[act], home[i]) << joint;
  }
  EXPECT_EQ(Qpos("robot_0/gripper/left_driver_joint"), 0.00296);
  EXPECT_EQ(Qpos("robot_0/gripper/left_follower_joint"), -0.00296);
  const Array7 base = ToArray7(env_.GetRobotBasePose());
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(base[i], ToArray7(Base())[i], 1e-15) << i;
  const Array7 block = ToArray7(env_.GetBodyPose("red_block"));
  EXPECT_NEAR(block[0], 0.4, 1e-12);
  EXPECT_NEAR(block[1], 0.0, 1e-12);
  EXPECT_NEAR(block[2], 0.025, 1e-12);
  // Forward ran: the arm root sits on the base.
  const int link0 = env_.BodyId("robot_0/fr3_link0");
  EXPECT_NEAR(env_.data()->xpos[3 * link0 + 0], 0.1, 1e-12);
  EXPECT_NEAR(env_.data()->xpos[3 * link0 + 1], -0.2, 1e-12);
}

TEST_F(EnvTest, ResetRestoresHomeAndObjectPosesExactly) {
  const std::vector<double> qpos0(env_.data()->qpos, env_.data()->qpos + env_.model()->nq);
  const std::vector<double> ctrl0(env_.data()->ctrl, env_.data()->ctrl + env_.model()->nu);
  const Pose base0 = env_.GetRobotBasePose();
  env_.SetBodyPose("red_block", {{0.6, 0.3, 0.4}, {0, 0, 0, 1}});
  env_.SetRobotBasePose({{1, 1, 0}, {0, 0, 0, 1}});
  env_.data()->ctrl[0] = 0.5;
  for (int i = 0; i < 200; ++i) mj_step(env_.model(), env_.data());
  ASSERT_NE(std::vector<double>(env_.data()->qpos, env_.data()->qpos + env_.model()->nq), qpos0);
  const mjModel* model_before = env_.model();
  env_.Reset();
  EXPECT_EQ(env_.model(), model_before);  // no recompile
  EXPECT_EQ(std::vector<double>(env_.data()->qpos, env_.data()->qpos + env_.model()->nq), qpos0);
  EXPECT_EQ(std::vector<double>(env_.data()->ctrl, env_.data()->ctrl + env_.model()->nu), ctrl0);
  EXPECT_EQ(env_.GetRobotBasePose(), base0);
  EXPECT_EQ(env_.data()->time, 0.0);
  for (int i = 0; i < env_.model()->nv; ++i) EXPECT_EQ(env_.data()->qvel[i], 0.0);
}

TEST_F(EnvTest, SetGetPoseRoundTrip) {
  const double h = std::sqrt(0.5);
  const Array7 block = {0.55, -0.1, 0.3, h, 0, 0, h};
  env_.SetBodyPose("red_block", FromArray7(block));
  Array7 got = ToArray7(env_.GetBodyPose("red_block"));
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(got[i], block[i], 1e-15) << i;
  env_.ForwardPosition();
  const int id = env_.BodyId("red_block");
  EXPECT_NEAR(env_.data()->xpos[3 * id + 2], 0.3, 1e-12);

  const Pose base{{-0.3, 0.2, 0.05}, {0, 0, 0, 2}};  // normalised on write
  env_.SetRobotBasePose(base);
  EXPECT_EQ(env_.GetRobotBasePose(), (Pose{{-0.3, 0.2, 0.05}, {0, 0, 0, 1}}));
  env_.ForwardPosition();
  const int link0 = env_.BodyId("robot_0/fr3_link0");
  EXPECT_NEAR(env_.data()->xpos[3 * link0], -0.3, 1e-12);
  // A non-movable body reports its forward-kinematics pose.
  const Pose link = env_.GetBodyPose("robot_0/fr3_link0");
  EXPECT_NEAR(link.pos[1], 0.2, 1e-12);
}

TEST_F(EnvTest, ErrorsNameTheBody) {
  EXPECT_THAT([&] { env_.GetBodyPose("blue_block"); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("'blue_block'")));
  EXPECT_THAT([&] { env_.SetBodyPose("no_such", Pose{}); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("'no_such'")));
  EXPECT_THAT(
      [&] { env_.SetBodyPose("robot_0/fr3_link4", Pose{}); },
      ::testing::ThrowsMessage<Error>(::testing::AllOf(::testing::HasSubstr("'robot_0/fr3_link4'"),
                                                       ::testing::HasSubstr("cannot be moved"))));
  EXPECT_THAT(
      [&] {
        env_.SetBodyPose("red_block", {{0, 0, 0}, {0, 0, 0, 0}});
      },
      ::testing::ThrowsMessage<Error>(::testing::HasSubstr("zero quaternion")));
}

TEST(EnvCreateTest, SharedModelAndAHomePoseOfTheWrongLength) {
  Env env = Env::Load(kScene, FrankaDroidSpec(MLSPACES_SOURCE_DIR));
  std::shared_ptr<const mjModel> shared = env.shared_model();
  EXPECT_EQ(shared.get(), env.model());
  EXPECT_EQ(env.scene_key(), kScene.generic_string());

  RobotSpec bad = FrankaDroidSpec(MLSPACES_SOURCE_DIR);
  bad.home_arm = {0.0, 0.1};
  EXPECT_THAT([&] { Env::Load(kScene, bad); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("home arm pose has 2 values")));
}

TEST(EnvCreateTest, RobotConfigGravcompSwitchesMuJoCosGravcompOnTheRobotBodies) {
  for (bool on : {true, false}) {
    RobotSpec spec = FrankaDroidSpec(MLSPACES_SOURCE_DIR);
    spec.gravcomp = on;
    Env env = Env::Load(kScene, spec);
    const mjModel* m = env.model();
    const int root = mj_name2id(m, mjOBJ_BODY, "robot_0/fr3_link0");
    ASSERT_GE(root, 0);
    int robot_bodies = 0;
    for (int b = 1; b < m->nbody; ++b) {
      int a = b;
      while (a > 0 && a != root) a = m->body_parentid[a];
      if (a == root) {
        ++robot_bodies;
        EXPECT_EQ(m->body_gravcomp[b], on ? 1 : 0) << b;
      } else {
        EXPECT_EQ(m->body_gravcomp[b], 0) << b;  // the scene's bodies keep their own (none)
      }
    }
    EXPECT_EQ(robot_bodies, 13);
    EXPECT_EQ(m->ngravcomp, on ? 13 : 0);
    // MuJoCo's gravcomp force is there exactly when it is on.
    mj_forward(m, env.data());
    double largest = 0;
    for (int v = 0; v < m->nv; ++v) {
      largest = std::max(largest, std::abs(env.data()->qfrc_gravcomp[v]));
    }
    if (on) {
      EXPECT_GT(largest, 1);
    } else {
      EXPECT_EQ(largest, 0);
    }
  }
}

}  // namespace
}  // namespace mlspaces::datagen

namespace mlspaces::datagen {
namespace {

TEST(EnvPedestalTest, RobotStandsOnABoxAndTheBaseStaysOnTheFloor) {
  RobotSpec spec = FrankaDroidSpec(MLSPACES_SOURCE_DIR, Base());
  spec.pedestal_size = std::array<double, 3>{0.5, 0.4, 0.58};
  Env env = Env::Load(kScene, spec);
  const mjModel* m = env.model();
  const int box = mj_name2id(m, mjOBJ_GEOM, "robot_0/pedestal");
  ASSERT_GE(box, 0);
  EXPECT_NEAR(m->geom_size[3 * box + 0], 0.25, 1e-12);
  EXPECT_NEAR(m->geom_size[3 * box + 1], 0.20, 1e-12);
  EXPECT_NEAR(m->geom_size[3 * box + 2], 0.29, 1e-12);
  EXPECT_EQ(m->geom_bodyid[box], env.BodyId("robot_0/base"));
  // The base pose is the floor pose; the arm root sits on the pedestal's top.
  EXPECT_NEAR(env.GetRobotBasePose().pos[2], 0.0, 1e-12);
  const int link0 = env.BodyId("robot_0/fr3_link0");
  EXPECT_NEAR(env.data()->xpos[3 * link0 + 2], 0.58, 1e-12);
  EXPECT_NEAR(env.data()->xpos[3 * link0 + 0], 0.1, 1e-12);
  EXPECT_NEAR(env.data()->xpos[3 * link0 + 1], -0.2, 1e-12);
  // Everything the robot needs came along: servos, gripper, TCP.
  EXPECT_GE(mj_name2id(m, mjOBJ_ACTUATOR, "robot_0/fr3_joint7"), 0);
  EXPECT_GE(mj_name2id(m, mjOBJ_ACTUATOR, "robot_0/gripper/fingers_actuator"), 0);
  EXPECT_GE(mj_name2id(m, mjOBJ_SITE, "robot_0/gripper/grasp_site"), 0);
  // No temp file is left behind.
  for (const auto& e :
       std::filesystem::directory_iterator(std::filesystem::temp_directory_path())) {
    EXPECT_EQ(e.path().filename().string().rfind("mlspaces_pedestal_", 0), std::string::npos);
  }
}

}  // namespace
}  // namespace mlspaces::datagen
