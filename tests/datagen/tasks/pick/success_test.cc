// Pick success and reward on the example scene (examples/custom_assets/scene.xml) with the
// franka_droid robot attached under "robot_0/", states set by hand.
#include "mlspaces/datagen/tasks/pick/success.h"

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::IsEmpty;

constexpr double kStartZ = 0.025;  // the block's rest height in scene.xml

class SuccessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    sim::MjcfComposer composer(fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/scene.xml");
    Pose base;
    base.pos = {-0.2, 0, 0};
    composer.Attach(fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid/franka_droid.xml",
                    "world", "robot_0/", base);
    // A second block, parked far away until a test moves it.
    Pose far;
    far.pos = {1.5, 1.5, 0.5};
    composer.Attach(
        fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/asset_library/red_block/red_block.xml",
        "world", "other/", far);
    model_ = composer.Compile();
    data_ = sim::MakeData(model_.get());
    m_ = model_.get();
    d_ = data_.get();
    block_ = mj_name2id(m_, mjOBJ_BODY, "red_block");
    other_ = mj_name2id(m_, mjOBJ_BODY, "other/red_block");
    pad_ = mj_name2id(m_, mjOBJ_GEOM, "robot_0/gripper/left_pad2");
    ASSERT_GT(block_, 0);
    ASSERT_GT(other_, 0);
    ASSERT_GE(pad_, 0);
    mj_forward(m_, d_);
  }

  // Puts a free body's origin at `pos` (identity orientation, at rest) and recomputes
  // positions and contacts.
  void Place(int body, double x, double y, double z) {
    const int adr = m_->jnt_qposadr[m_->body_jntadr[body]];
    const double q[7] = {x, y, z, 1, 0, 0, 0};
    for (int i = 0; i < 7; ++i) d_->qpos[adr + i] = q[i];
    mj_forward(m_, d_);
  }

  PickSuccess Judge() { return EvaluatePickSuccess(m_, d_, block_, kStartZ); }

  sim::ModelPtr model_;
  sim::DataPtr data_;
  const mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
  int block_ = -1, other_ = -1, pad_ = -1;
};

TEST_F(SuccessTest, BlockRestingOnFloorIsNotSuccess) {
  Place(block_, 0.4, 0, kStartZ - 0.0005);  // pressed 0.5 mm into the floor
  const PickSuccess r = Judge();
  EXPECT_NEAR(r.lift, -0.0005, 1e-9);
  EXPECT_FALSE(r.lifted);
  EXPECT_EQ(r.robot_contacts, 0);
  EXPECT_GE(r.other_contacts, 1);
  EXPECT_THAT(r.non_robot_geoms, ElementsAre("floor"));
  EXPECT_FALSE(r.only_robot_contact);
  EXPECT_FALSE(r.success);
  ASSERT_GE(r.supporting_geom, 0);
  EXPECT_EQ(sim::MjName(m_, mjOBJ_GEOM, r.supporting_geom), "floor");
  EXPECT_EQ(r.reward, 0);
}

TEST_F(SuccessTest, LiftedInFreeSpaceTouchesNothingButIsNotHeld) {
  Place(block_, 0.4, 0, kStartZ + 0.02);
  const PickSuccess r = Judge();
  EXPECT_NEAR(r.lift, 0.02, 1e-9);
  EXPECT_TRUE(r.lifted);
  EXPECT_EQ(r.robot_contacts, 0);
  EXPECT_EQ(r.other_contacts, 0);
  EXPECT_THAT(r.non_robot_geoms, IsEmpty());
  // Spec 6.2: only_robot_contact needs at least one robot contact; a block in free fall (or
  // thrown) on the final state is not a pick.
  EXPECT_FALSE(r.only_robot_contact);
  EXPECT_FALSE(r.success);
  // Nothing supports it: the reward is the lift.
  EXPECT_EQ(r.supporting_geom, -1);
  EXPECT_NEAR(r.reward, 0.02, 1e-9);
}

TEST_F(SuccessTest, LiftHeightThresholdIsInclusiveAndConfigurable) {
  Place(block_, 0.4, 0, kStartZ + 0.005);
  EXPECT_FALSE(Judge().lifted);
  EXPECT_TRUE(EvaluatePickSuccess(m_, d_, block_, kStartZ, "robot_0/", 0.005).lifted);
  EXPECT_FALSE(EvaluatePickSuccess(m_, d_, block_, kStartZ, "robot_0/", 0.0051).lifted);
}

TEST_F(SuccessTest, BlockInTheGripperIsSuccess) {
  const double* p = d_->geom_xpos + 3 * pad_;
  ASSERT_GT(p[2], 0.1);  // the gripper is well above the floor at the home pose
  Place(block_, p[0], p[1], p[2]);
  const PickSuccess r = Judge();
  EXPECT_NEAR(r.lift, p[2] - kStartZ, 1e-9);
  EXPECT_TRUE(r.lifted);
  EXPECT_GE(r.robot_contacts, 1);
  EXPECT_EQ(r.other_contacts, 0);
  EXPECT_THAT(r.non_robot_geoms, IsEmpty());
  EXPECT_TRUE(r.only_robot_contact);
  EXPECT_TRUE(r.success);
  // Supported by the robot (a visible robot geom) or by nothing: reward = lift.
  if (r.supporting_geom >= 0) {
    EXPECT_TRUE(IsRobotBody(m_, m_->geom_bodyid[r.supporting_geom], "robot_0/"));
  }
  EXPECT_NEAR(r.reward, r.lift, 1e-9);
  // With another prefix the same contacts are not the robot's.
  const PickSuccess wrong = EvaluatePickSuccess(m_, d_, block_, kStartZ, "robot_1/");
  EXPECT_FALSE(wrong.success);
  EXPECT_EQ(wrong.robot_contacts, 0);
  EXPECT_FALSE(wrong.non_robot_geoms.empty());
}

TEST_F(SuccessTest, HeldButTouchingAnotherObjectFailsAndNamesIt) {
  const double* p = d_->geom_xpos + 3 * pad_;
  const double x = p[0], y = p[1], z = p[2];
  Place(block_, x, y, z);
  Place(other_, x, y, z - 0.0495);  // right below, overlapping 0.5 mm
  const PickSuccess r = Judge();
  EXPECT_TRUE(r.lifted);
  EXPECT_GE(r.robot_contacts, 1);
  EXPECT_GE(r.other_contacts, 1);
  EXPECT_THAT(r.non_robot_geoms, ElementsAre("other/red_block_geom"));
  EXPECT_FALSE(r.only_robot_contact);
  EXPECT_FALSE(r.success);
  // Resting on the other block: that block supports it, so no reward.
  ASSERT_GE(r.supporting_geom, 0);
  EXPECT_EQ(sim::MjName(m_, mjOBJ_GEOM, r.supporting_geom), "other/red_block_geom");
  EXPECT_EQ(r.reward, 0);
}

TEST_F(SuccessTest, LiftedButTouchingTheFloorFails) {
  // Tilted 45 degrees about x and raised so a bottom edge still digs into the floor: the
  // origin rose by just over 1 cm but the floor is touched.
  const int adr = m_->jnt_qposadr[m_->body_jntadr[block_]];
  const double half = 0.025 * std::sqrt(2.0);  // centre-to-edge height when tilted 45 deg
  const double q[7] = {
      0.4, 0, half - 0.0002, std::cos(std::numbers::pi / 8), std::sin(std::numbers::pi / 8), 0, 0};
  for (int i = 0; i < 7; ++i) d_->qpos[adr + i] = q[i];
  mj_forward(m_, d_);
  const PickSuccess r = Judge();
  EXPECT_GT(r.lift, 0.01);
  EXPECT_TRUE(r.lifted);
  EXPECT_THAT(r.non_robot_geoms, ElementsAre("floor"));
  EXPECT_FALSE(r.success);
}

TEST_F(SuccessTest, RobotBodies) {
  EXPECT_TRUE(IsRobotBody(m_, mj_name2id(m_, mjOBJ_BODY, "robot_0/base"), "robot_0/"));
  EXPECT_TRUE(IsRobotBody(m_, m_->geom_bodyid[pad_], "robot_0/"));
  EXPECT_FALSE(IsRobotBody(m_, 0, "robot_0/"));  // the world
  EXPECT_FALSE(IsRobotBody(m_, block_, "robot_0/"));
  EXPECT_FALSE(IsRobotBody(m_, other_, "robot_0/"));
}

TEST_F(SuccessTest, BadArguments) {
  EXPECT_THROW(EvaluatePickSuccess(m_, d_, 0, kStartZ), UsageError);
  EXPECT_THROW(EvaluatePickSuccess(m_, d_, m_->nbody, kStartZ), UsageError);
  EXPECT_THROW(EvaluatePickSuccess(m_, d_, block_, kStartZ, ""), UsageError);
  EXPECT_THROW(EvaluatePickSuccess(m_, d_, block_, kStartZ, "robot_0/", -1), UsageError);
}

}  // namespace
}  // namespace mlspaces::datagen
