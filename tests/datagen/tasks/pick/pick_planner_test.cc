#include "mlspaces/datagen/tasks/pick/pick_planner.h"

#include <cmath>
#include <filesystem>
#include <functional>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/se3.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/library/registry.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

using ::testing::HasSubstr;

const std::filesystem::path kExample =
    std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

class PickPlannerTest : public ::testing::Test {
 protected:
  PickPlannerTest()
      : config_(LoadConfigFile(kExample / "datagen.yaml", ConfigRegistry::WithBuiltins())),
        env_(Env::Create(sim::Scene::Load(kExample / "scene.xml"),
                         RobotSpecFromConfig(config_.robot_config), "house_0")),
        robot_(env_.model(), env_.robot()),
        planner_(env_, robot_, config_.policy_config, config_.policy_dt_ms / 1000.0),
        block_(env_.BodyId("red_block")) {
    Registry registry;
    config_.libraries.ApplyTo(registry);
    grasps_ = registry.LoadGrasps({"red_block"}).poses;
  }

  double BlockZ() const { return env_.data()->xpos[3 * block_ + 2]; }

  // Runs the planner like the episode runner (no action noise) until it is done or
  // `max_steps` policy steps passed; `before_step` may tamper with the state or the action.
  int Drive(int max_steps,
            const std::function<void(PlannerAction&, int step)>& before_step = nullptr) {
    mjData* d = env_.data();
    for (int step = 0; step < max_steps; ++step) {
      PlannerAction a = planner_.Act(d);
      phases_.push_back(planner_.phase());
      if (before_step) before_step(a, step);
      robot_.SetArmTargets(d, a.arm);
      robot_.SetGripperCtrl(d, a.gripper);
      robot_.Step(d, 33);
      mj_forward(env_.model(), d);
      if (a.done) return step + 1;
    }
    return -1;
  }

  ExperimentConfig config_;
  Env env_;
  robots::RobotView robot_;
  PickPlanner planner_;
  int block_;
  std::vector<Mat4> grasps_;
  std::vector<PolicyPhase> phases_;
};

TEST_F(PickPlannerTest, PlansTheLibraryGraspAndLiftsTheBlockThroughThePhases) {
  ASSERT_EQ(grasps_.size(), 1u);
  ASSERT_EQ(planner_.Reset(env_.data(), block_, grasps_), PlanFailure::kNone) << planner_.message();
  // Top-down at the block centre (the grasp or its flip).
  const Mat4& g = planner_.grasp_pose();
  EXPECT_NEAR(g(2, 2), -1.0, 1e-9);
  EXPECT_NEAR(g(0, 3), 0.4, 1e-9);
  EXPECT_NEAR(g(2, 3), 0.025, 1e-9);
  EXPECT_EQ(planner_.stats().num_candidates, 2u);
  EXPECT_EQ(planner_.stats().num_collision_free, 2u);
  const double z0 = BlockZ();
  const int steps = Drive(200);
  ASSERT_GT(steps, 0) << "the plan never finished";
  // About 2 s to the pregrasp, 0.5 s down, settle, 0.5 s close, 1 s lift, settle: ~4.2 s.
  EXPECT_NEAR(steps * 0.066, 4.2, 0.4);
  EXPECT_FALSE(planner_.gave_up());
  EXPECT_EQ(planner_.retries(), 0);
  EXPECT_EQ(planner_.failure(), PlanFailure::kNone);
  // Phases run in order: pregrasp, grasp, gripper-close, lift.
  std::vector<PolicyPhase> order;
  for (PolicyPhase p : phases_) {
    if (order.empty() || order.back() != p) order.push_back(p);
  }
  EXPECT_EQ(order, (std::vector<PolicyPhase>{PolicyPhase::kPregrasp, PolicyPhase::kGrasp,
                                             PolicyPhase::kGripperClose, PolicyPhase::kLift}));
  EXPECT_NEAR(BlockZ() - z0, config_.policy_config.postgrasp_z_offset, 0.01);
  EXPECT_GT(robot_.InterFingerDistance(env_.data()), 0.045);  // the block is between the pads
  // After done the planner keeps answering done with the last command.
  EXPECT_TRUE(planner_.Act(env_.data()).done);
}

TEST_F(PickPlannerTest, NoGraspsMeansNoGrasp) {
  EXPECT_EQ(planner_.Reset(env_.data(), block_, {}), PlanFailure::kNoGrasp);
  EXPECT_TRUE(planner_.gave_up());
  EXPECT_THAT(planner_.message(), HasSubstr("no grasps"));
  EXPECT_TRUE(planner_.Act(env_.data()).done);
}

TEST_F(PickPlannerTest, GraspsInsideTheFloorAreRejectedByTheProbe) {
  std::vector<Mat4> low = grasps_;
  low[0](2, 3) -= 0.05;  // TCP 2.5 cm below the floor
  EXPECT_EQ(planner_.Reset(env_.data(), block_, low), PlanFailure::kNoGrasp);
  EXPECT_THAT(planner_.message(), HasSubstr("collides"));
  EXPECT_EQ(planner_.stats().num_collision_free, 0u);
}

TEST_F(PickPlannerTest, UnreachableObjectHasNoFeasibleGrasp) {
  env_.SetBodyPose("red_block", {{2.5, 0, 0.025}, {1, 0, 0, 0}});
  env_.Forward();
  EXPECT_EQ(planner_.Reset(env_.data(), block_, grasps_), PlanFailure::kNoGrasp);
  EXPECT_THAT(planner_.message(), HasSubstr("IK failed"));
}

TEST_F(PickPlannerTest, BlockedArmRetriesThenGivesUpAsCollision) {
  ASSERT_EQ(planner_.Reset(env_.data(), block_, grasps_), PlanFailure::kNone);
  const std::vector<double> frozen = robot_.ArmQpos(env_.data());
  // The arm never moves: the TCP falls behind its target.
  const int steps = Drive(400, [&](PlannerAction& a, int) { a.arm = frozen; });
  ASSERT_GT(steps, 0);
  EXPECT_TRUE(planner_.gave_up());
  EXPECT_EQ(planner_.failure(), PlanFailure::kCollision);
  EXPECT_EQ(planner_.retries(), config_.policy_config.max_retries);
  EXPECT_THAT(planner_.message(), HasSubstr("from its target"));
}

TEST_F(PickPlannerTest, ObjectMovedAwayBeforeTheCloseIsRetriedAndPickedWhereItIs) {
  ASSERT_EQ(planner_.Reset(env_.data(), block_, grasps_), PlanFailure::kNone);
  bool moved = false;
  const int steps = Drive(400, [&](PlannerAction&, int) {
    if (!moved && planner_.phase() == PolicyPhase::kGripperClose) {
      env_.SetBodyPose("red_block", {{0.45, 0.15, 0.025}, {1, 0, 0, 0}});
      env_.Forward();
      moved = true;
    }
  });
  ASSERT_TRUE(moved);
  ASSERT_GT(steps, 0);
  EXPECT_FALSE(planner_.gave_up())
      << planner_.message() << " " << PlanFailureName(planner_.failure());
  EXPECT_EQ(planner_.retries(), 1);
  EXPECT_EQ(planner_.failure(), PlanFailure::kEmptyGrasp);  // what the retry was for
  EXPECT_NEAR(planner_.grasp_pose()(1, 3), 0.15, 1e-6);
  EXPECT_GT(BlockZ(), 0.025 + 0.05);
}

TEST_F(PickPlannerTest, TravelAboveTheGraspIsAStraightLineInJointSpace) {
  ASSERT_EQ(planner_.Reset(env_.data(), block_, grasps_), PlanFailure::kNone);
  const std::vector<double> q0 = robot_.ArmQpos(env_.data());
  std::vector<std::vector<double>> pregrasp_phase;
  Drive(200, [&](PlannerAction& a, int) {
    if (planner_.phase() == PolicyPhase::kPregrasp) pregrasp_phase.push_back(a.arm);
  });
  // The phase is the joint travel to the lift pose, then a 4 cm Cartesian descent (0.2 s at
  // speed_fast: at most 4 policy steps with the one-step look-ahead).
  ASSERT_GT(pregrasp_phase.size(), 10u);
  const std::vector<std::vector<double>> travel(pregrasp_phase.begin(), pregrasp_phase.end() - 4);
  const std::vector<double>& last = travel.back();
  size_t big = 0;
  for (size_t i = 1; i < 7; ++i) {
    if (std::abs(last[i] - q0[i]) > std::abs(last[big] - q0[big])) big = i;
  }
  // Every command on the travel is q0 + s (q_end - q0) for one s per step, s increasing.
  double prev_s = 0;
  for (const std::vector<double>& q : travel) {
    const double s = (q[big] - q0[big]) / (last[big] - q0[big]);
    EXPECT_GE(s, prev_s);
    prev_s = s;
    for (size_t i = 0; i < 7; ++i) EXPECT_NEAR(q[i], q0[i] + s * (last[i] - q0[i]), 1e-9) << i;
  }
}

TEST(PolicyPhaseMapTest, IsTheOriginalsMap) {
  const Json map = PolicyPhaseMap();
  EXPECT_EQ(map.size(), 10u);
  EXPECT_EQ(map["gripper-close"], 4);
  EXPECT_EQ(map["lift"], static_cast<int>(PolicyPhase::kLift));
  EXPECT_EQ(map["go_home"], 9);
}

}  // namespace
}  // namespace mlspaces::datagen
