#include "mlspaces/datagen/task_sampler.h"

#include <cmath>
#include <filesystem>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/se3.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

const std::filesystem::path kScene =
    std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "scene.xml";

// Yaw (about world z) of a quaternion that only rotates about z.
double Yaw(const Array7& p) { return 2.0 * std::atan2(p[6], p[3]); }

double WrapAngle(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }

class TaskSamplerTest : public ::testing::Test {
 protected:
  TaskSamplerTest() : env_(Env::Load(kScene, FrankaDroidSpec(MLSPACES_SOURCE_DIR))) {}
  Env env_;
  ExperimentConfig config_;
  TaskSamplerRegistry registry_ = TaskSamplerRegistry::WithBuiltins();
};

TEST_F(TaskSamplerTest, BlockPickupIsDeterministicPerEpisode) {
  auto a = registry_.Create(config_, 7);
  auto b = registry_.Create("BLOCK_PICKUP", config_, 7);
  EXPECT_EQ(a->name(), "block_pickup");
  const Task t1 = a->SampleTask(env_, 3);
  const std::vector<double> qpos1(env_.data()->qpos, env_.data()->qpos + env_.model()->nq);
  a->SampleTask(env_, 4);  // state in between must not matter
  const Task t2 = b->SampleTask(env_, 3);
  const std::vector<double> qpos2(env_.data()->qpos, env_.data()->qpos + env_.model()->nq);
  EXPECT_EQ(t1.pickup_obj_name, "red_block");
  EXPECT_EQ(t1.robot_base_pose, t2.robot_base_pose);
  EXPECT_EQ(t1.pickup_obj_start_pose, t2.pickup_obj_start_pose);
  EXPECT_EQ(t1.pickup_obj_goal_pose, t2.pickup_obj_goal_pose);
  EXPECT_EQ(t1.seed, t2.seed);
  EXPECT_EQ(t1.seed, EpisodeSeed(7, kScene.generic_string(), 3));
  EXPECT_EQ(qpos1, qpos2);

  const Task other = a->SampleTask(env_, 5);
  EXPECT_NE(other.robot_base_pose, t1.robot_base_pose);
  EXPECT_NE(other.pickup_obj_start_pose, t1.pickup_obj_start_pose);
  auto c = registry_.Create(config_, 8);
  EXPECT_NE(c->SampleTask(env_, 3).robot_base_pose, t1.robot_base_pose);
}

TEST_F(TaskSamplerTest, BlockPickupNoiseWithinBoundsAndGoalAboveStart) {
  config_.task_sampler_config.goal_offset_z = 0.07;
  auto sampler = registry_.Create(config_, 11);
  const auto& cfg = config_.task_sampler_config;
  double max_rx = 0, max_ryaw = 0, max_ox = 0, max_oyaw = 0;
  for (int64_t ep = 0; ep < 200; ++ep) {
    const Task t = sampler->SampleTask(env_, ep);
    // Base starts at the identity: the noise is the pose itself.
    const Array7 b = ToArray7(t.robot_base_pose);
    EXPECT_LE(std::abs(b[0]), cfg.robot_base_noise.x);
    EXPECT_LE(std::abs(b[1]), cfg.robot_base_noise.y);
    EXPECT_EQ(b[2], 0.0);
    EXPECT_NEAR(b[4], 0.0, 1e-15);
    EXPECT_NEAR(b[5], 0.0, 1e-15);
    const double ryaw = Yaw(b) * 180 / std::numbers::pi;
    EXPECT_LE(std::abs(ryaw), cfg.robot_base_noise.yaw_deg + 1e-9);
    // Block starts at (0.4, 0, 0.025), unrotated: offsets are in its own (identity) frame.
    const Array7 s = ToArray7(t.pickup_obj_start_pose);
    EXPECT_LE(std::abs(s[0] - 0.4), cfg.object_noise.x + 1e-12);
    EXPECT_LE(std::abs(s[1]), cfg.object_noise.y + 1e-12);
    EXPECT_NEAR(s[2], 0.025, 1e-12);
    const double oyaw = WrapAngle(Yaw(s)) * 180 / std::numbers::pi;
    EXPECT_LE(std::abs(oyaw), cfg.object_noise.yaw_deg + 1e-9);
    // The env holds the sampled state.
    EXPECT_EQ(env_.GetBodyPose("red_block"), t.pickup_obj_start_pose);
    EXPECT_EQ(env_.GetRobotBasePose(), t.robot_base_pose);
    // Goal = start + offset along world z.
    Array7 goal = s;
    goal[2] += 0.07;
    EXPECT_EQ(ToArray7(t.pickup_obj_goal_pose), goal);
    max_rx = std::max(max_rx, std::abs(b[0]));
    max_ryaw = std::max(max_ryaw, std::abs(ryaw));
    max_ox = std::max(max_ox, std::abs(s[0] - 0.4));
    max_oyaw = std::max(max_oyaw, std::abs(oyaw));
  }
  // The noise actually spans its range.
  EXPECT_GT(max_rx, 0.8 * cfg.robot_base_noise.x);
  EXPECT_GT(max_ryaw, 0.8 * cfg.robot_base_noise.yaw_deg);
  EXPECT_GT(max_ox, 0.8 * cfg.object_noise.x);
  EXPECT_GT(max_oyaw, 0.8 * cfg.object_noise.yaw_deg);
}

TEST(ComposePlanarTest, MovesInThePoseFrame) {
  const double h = std::sqrt(0.5);
  // Rotated 90 deg about z: a local +x step is a world +y step.
  const Array7 p = ToArray7(ComposePlanar({{1, 2, 3}, {h, 0, 0, h}}, 0.1, 0, std::numbers::pi / 2));
  EXPECT_NEAR(p[0], 1.0, 1e-12);
  EXPECT_NEAR(p[1], 2.1, 1e-12);
  EXPECT_NEAR(p[2], 3.0, 1e-12);
  EXPECT_NEAR(std::abs(p[3]), 0.0, 1e-12);  // 180 deg total
  EXPECT_NEAR(std::abs(p[6]), 1.0, 1e-12);
}

// The tutorial's pattern: a user subclass that fixes the base and lifts the goal 10 cm.
class FixedBaseSampler : public TaskSampler {
 public:
  using TaskSampler::TaskSampler;

 protected:
  void SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) override {
    env.SetRobotBasePose({{-0.1, 0, 0}, {1, 0, 0, 0}});
    const Pose start = env.GetBodyPose(*draft.pickup_obj_name);
    Pose moved = start;
    moved.pos[1] += rng.Uniform(-0.01, 0.01);
    env.SetBodyPose(*draft.pickup_obj_name, moved);
    draft.robot_base_pose = env.GetRobotBasePose();
    draft.pickup_obj_start_pose = moved;
    Pose goal = moved;
    goal.pos[2] += 0.1;
    draft.pickup_obj_goal_pose = goal;
  }
};

// Forgets the goal.
class ForgetfulSampler : public TaskSampler {
 public:
  using TaskSampler::TaskSampler;

 protected:
  void SampleAndPlaceRobot(Env& env, Rng&, TaskDraft& draft) override {
    draft.robot_base_pose = env.GetRobotBasePose();
    draft.pickup_obj_start_pose = env.GetBodyPose(*draft.pickup_obj_name);
  }
};

// Chooses no object and a bad quaternion.
class BadSampler : public TaskSampler {
 public:
  using TaskSampler::TaskSampler;
  std::string object;

 protected:
  std::string SelectPickupObject(Env&, Rng&) override { return object; }
  void SampleAndPlaceRobot(Env&, Rng&, TaskDraft& draft) override {
    const Pose p;
    draft.robot_base_pose = Pose{{0, 0, 0}, {2, 0, 0, 0}};
    draft.pickup_obj_start_pose = p;
    draft.pickup_obj_goal_pose = p;
  }
};

TEST_F(TaskSamplerTest, CustomSubclassRegisteredByName) {
  registry_.Register("FixedBase", [](const ExperimentConfig& c, uint64_t seed) {
    return std::make_unique<FixedBaseSampler>(c, seed);
  });
  EXPECT_TRUE(registry_.Contains("fixedbase"));
  EXPECT_EQ(
      registry_.names(),
      (std::vector<std::string>{"block_pickup", "FixedBase", "OpenTaskSampler",
                                "PickAndPlaceColorTaskSampler", "PickAndPlaceNextToTaskSampler",
                                "PickAndPlaceReceptacleTaskSampler", "PickAndPlaceTaskSampler"}));
  config_.task_sampler_config.task_sampler_class = "fixedBASE";
  auto sampler = registry_.Create(config_, 1);
  EXPECT_EQ(sampler->name(), "FixedBase");
  const Task t = sampler->SampleTask(env_, 0);
  EXPECT_EQ(t.robot_base_pose, (Pose{{-0.1, 0, 0}, {1, 0, 0, 0}}));
  EXPECT_EQ(t.pickup_obj_name, "red_block");
  EXPECT_NEAR(t.pickup_obj_goal_pose.pos[2] - t.pickup_obj_start_pose.pos[2], 0.1, 1e-15);
  EXPECT_LE(std::abs(t.pickup_obj_start_pose.pos[1]), 0.01);
  EXPECT_EQ(env_.GetBodyPose("red_block"), t.pickup_obj_start_pose);

  EXPECT_THROW(registry_.Register("FIXEDBASE",
                                  [](const ExperimentConfig& c, uint64_t s) {
                                    return std::make_unique<FixedBaseSampler>(c, s);
                                  }),
               UsageError);
}

TEST_F(TaskSamplerTest, UnknownNameListsValidOnes) {
  try {
    registry_.Create("BlockPickupTaskSampler", config_, 1);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("BlockPickupTaskSampler"), HasSubstr("block_pickup")));
    EXPECT_EQ(e.field(), "/task_sampler_config/task_sampler_class");
  }
}

TEST_F(TaskSamplerTest, MissingRequiredFieldIsANamedError) {
  registry_.Register("forgetful", [](const ExperimentConfig& c, uint64_t seed) {
    return std::make_unique<ForgetfulSampler>(c, seed);
  });
  auto sampler = registry_.Create("forgetful", config_, 1);
  try {
    sampler->SampleTask(env_, 0);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "pickup_obj_goal_pose");
    EXPECT_THAT(e.what(), AllOf(HasSubstr("'forgetful'"), HasSubstr("did not set")));
  }

  BadSampler bad(config_, 1);
  EXPECT_THAT([&] { bad.SampleTask(env_, 0); },
              ThrowsMessage<Error>(HasSubstr("did not set pickup_obj_name")));
  bad.object = "ghost";
  EXPECT_THAT([&] { bad.SampleTask(env_, 0); },
              ThrowsMessage<Error>(HasSubstr("'ghost', which is not a body")));
  bad.object = "red_block";
  EXPECT_THAT([&] { bad.SampleTask(env_, 0); },
              ThrowsMessage<Error>(AllOf(HasSubstr("robot_base_pose"), HasSubstr("not unit"))));
}

TEST_F(TaskSamplerTest, PresetPickupObjectAndRandomisedArm) {
  config_.task_config.pickup_obj_name = "ghost";
  auto sampler = registry_.Create(config_, 2);
  EXPECT_THAT([&] { sampler->SampleTask(env_, 0); }, ThrowsMessage<Error>(HasSubstr("'ghost'")));
  config_.task_config.pickup_obj_name.reset();
  auto ok = registry_.Create(config_, 2);
  ok->SampleTask(env_, 0);
  const std::vector<double>& noise = env_.robot().home_noise;
  ASSERT_EQ(noise.size(), 7u);
  bool moved = false;
  for (size_t i = 0; i < 7; ++i) {
    const double q = env_.data()->qpos[env_.arm_qpos_adr()[i]];
    EXPECT_LE(std::abs(q - env_.home_qpos()[i]), noise[i]);
    moved = moved || q != env_.home_qpos()[i];
  }
  EXPECT_TRUE(moved);
}

}  // namespace
}  // namespace mlspaces::datagen
