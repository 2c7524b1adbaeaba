#include "mlspaces/datagen/episode_runner.h"

#include <filesystem>
#include <memory>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/recorder.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

using ::testing::HasSubstr;

const std::filesystem::path kExample =
    std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

ExperimentConfig TutorialConfig() {
  return LoadConfigFile(kExample / "datagen.yaml", ConfigRegistry::WithBuiltins());
}

// Everything an EpisodeRunner needs, built as `mlspaces datagen` builds it.
struct Rig {
  explicit Rig(ExperimentConfig c, uint64_t seed = 3,
               const TaskSamplerRegistry& samplers = TaskSamplerRegistry::WithBuiltins())
      : config(std::move(c)),
        env(Env::Create(sim::Scene::Load(kExample / "scene.xml"),
                        RobotSpecFromConfig(config.robot_config), "house_0")) {
    config.libraries.ApplyTo(registry);
    sampler = samplers.Create(config, seed);
    runner = std::make_unique<EpisodeRunner>(env, *sampler, registry, config);
  }
  ExperimentConfig config;
  Env env;
  Registry registry;
  std::unique_ptr<TaskSampler> sampler;
  std::unique_ptr<EpisodeRunner> runner;
};

TEST(EpisodeRunnerTest, TutorialEpisodesSucceedAndRecordEveryStep) {
  Rig rig(TutorialConfig());
  EXPECT_EQ(rig.runner->substeps(), 33);
  for (int64_t episode = 0; episode < 3; ++episode) {
    SCOPED_TRACE(episode);
    const EpisodeResult r = rig.runner->Run(episode);
    EXPECT_TRUE(r.success) << r.attempt.message;
    EXPECT_EQ(r.attempt.outcome, Outcome::kSuccess);
    EXPECT_EQ(r.attempt.episode, episode);
    EXPECT_EQ(r.attempt.seed, EpisodeSeed(3, "house_0", episode));
    EXPECT_GE(r.attempt.extra["lift"].get<double>(), 0.06);
    for (const char* stage : {"sample", "grasps", "plan", "policy", "physics", "observe"}) {
      EXPECT_GT(r.attempt.Timing(stage), 0.0) << stage;
    }
    ASSERT_TRUE(r.record.has_value());
    const EpisodeRecord& rec = *r.record;
    const size_t t = NumSteps(rec);
    EXPECT_EQ(static_cast<int64_t>(t), r.policy_steps + 1);
    EXPECT_EQ(r.physics_steps, r.policy_steps * 33);
    // ~4.2 s at 15 fps as the original (64 frames), more when the base lands farther away.
    EXPECT_GE(t, 55u);
    EXPECT_LE(t, 85u);
    EXPECT_NO_THROW(ValidateEpisode(rec));
    // Observation 0: dummy action; last: the done action, success, terminated.
    EXPECT_TRUE(rec.actions.at("commanded_action")[0].empty());
    EXPECT_EQ(rec.actions.at("commanded_action").back().at("arm").size(), 7u);
    EXPECT_TRUE(rec.actions.at("joint_pos").back().empty());
    EXPECT_EQ(rec.actions.at("joint_pos")[0].at("arm").size(), 7u);
    EXPECT_TRUE(rec.terminated.back());
    EXPECT_FALSE(rec.truncated.back());
    EXPECT_TRUE(rec.success.back());
    EXPECT_FALSE(rec.success.front());
    EXPECT_GT(rec.rewards.back(), 0.06f);
    EXPECT_EQ(rec.extra_json.at("grasp_state_pickup_obj").steps.back(),
              (Json{{"gripper", Json{{"touching", true}, {"held", true}}}}));
    EXPECT_EQ(rec.extra.at("policy_phase").steps(), t);
    // The block is an actor: its pose and velocity per step, lifted at the end.
    const Series& block = rec.env_states.at("actors/red_block");
    ASSERT_EQ(block.steps(), t);
    ASSERT_EQ(block.row_size(), 13u);
    const float* rows = reinterpret_cast<const float*>(block.bytes().data());
    EXPECT_GT(rows[13 * (t - 1) + 2] - rows[2], 0.06f);
    EXPECT_EQ(rec.meta.assets.at(0).uid, "red_block");
    EXPECT_EQ(rec.meta.assets.at(0).library, "custom_assets");
    EXPECT_EQ(rec.meta.task_description, "Pick up the block");
    EXPECT_EQ(rec.meta.config_hash, DataConfigHashHex(rig.config));
    EXPECT_EQ(rec.obs_scene["text"], "pick red_block");
  }
}

TEST(EpisodeRunnerTest, SameSeedSameTrajectoryBytes) {
  Rig a(TutorialConfig(), 11), b(TutorialConfig(), 11);
  testing::TempDir dir;
  RecorderOptions oa, ob;
  oa.dir = dir / "a";
  ob.dir = dir / "b";
  Recorder ra(oa), rb(ob);
  // b runs an unrelated episode first: an episode depends only on its own seed.
  b.runner->Run(7);
  for (int64_t e : {0, 1}) {
    ra.Write(*a.runner->Run(e).record);
    rb.Write(*b.runner->Run(e).record);
  }
  ASSERT_TRUE(ra.Finish());
  ASSERT_TRUE(rb.Finish());
  EXPECT_TRUE(testing::Slurp(ra.batch_file()) == testing::Slurp(rb.batch_file()));
  // Another seed: other bytes.
  Rig c(TutorialConfig(), 12);
  RecorderOptions oc;
  oc.dir = dir / "c";
  Recorder rc(oc);
  rc.Write(*c.runner->Run(0).record);
  rc.Write(*c.runner->Run(1).record);
  ASSERT_TRUE(rc.Finish());
  EXPECT_FALSE(testing::Slurp(ra.batch_file()) == testing::Slurp(rc.batch_file()));
}

// An episode's physics depends on nothing that ran before it, to the last bit (a resumed run
// re-simulates an episode in a fresh process and must render the same frames).
TEST(EpisodeRunnerTest, EpisodeStateIsBitIdenticalWhateverRanBefore) {
  Rig a(TutorialConfig(), 13), b(TutorialConfig(), 13);
  for (int64_t e : {0, 1, 12, 13, 24, 25, 26}) a.runner->Run(e);
  for (int64_t e : {24, 25, 26}) b.runner->Run(e);
  const mjModel* m = a.env.model();
  for (int i = 0; i < m->nq; ++i) {
    EXPECT_EQ(a.env.data()->qpos[i], b.env.data()->qpos[i]) << "qpos " << i;
  }
  for (int i = 0; i < m->nv; ++i) {
    EXPECT_EQ(a.env.data()->qvel[i], b.env.data()->qvel[i]) << "qvel " << i;
  }
}

// The same for the videos: an episode's MP4 bytes do not depend on what the process
// rendered and encoded before (x264's macroblock tree broke this; video.cc turns it off).
TEST(EpisodeRunnerTest, CameraVideosDependOnlyOnTheEpisode) {
  testing::TempDir dir;
  ExperimentConfig config = TutorialConfig();
  config.camera_config.img_resolution = {96, 64};
  config.camera_config.shadows = false;
  config.camera_config.reflections = false;
  auto run = [&](const std::string& sub, std::initializer_list<int64_t> episodes) {
    Rig rig(config, 13);
    EpisodeRunnerOptions options;
    options.video_dir = dir / sub;
    std::filesystem::create_directories(options.video_dir);
    EpisodeRunner runner(rig.env, *rig.sampler, rig.registry, rig.config, options);
    for (int64_t e : episodes) {
      const EpisodeResult r = runner.Run(e);
      ASSERT_TRUE(r.record.has_value());
      ASSERT_EQ(r.record->cameras.size(), 2u);
    }
  };
  run("after_others", {0, 1, 12, 13, 24, 25, 26});
  run("alone", {26});
  for (const char* cam : {"wrist_camera", "exo_camera_1"}) {
    const std::string name = CameraRecorder::TempVideoName(26, cam);
    const std::string a = testing::Slurp(dir / "after_others" / name);
    EXPECT_FALSE(a.empty());
    EXPECT_TRUE(a == testing::Slurp(dir / "alone" / name)) << cam;
  }
}

TEST(EpisodeRunnerTest, RecordingOffStillJudgesTheEpisode) {
  ExperimentConfig config = TutorialConfig();
  Rig rig(config);
  EpisodeRunnerOptions options;
  options.record = false;
  EpisodeRunner bare(rig.env, *rig.sampler, rig.registry, rig.config, options);
  const EpisodeResult r = bare.Run(0);
  EXPECT_TRUE(r.success);
  EXPECT_FALSE(r.record.has_value());
}

TEST(EpisodeRunnerTest, CommandedActionFollowsTheActionDtypeAndCommandMode) {
  ExperimentConfig config = TutorialConfig();
  config.task_config.action_dtype = ActionDtype::kFloat64;
  Rig absolute(config);
  const EpisodeRecord a = *absolute.runner->Run(0).record;
  config.robot_config.command_mode.arm = ArmCommandMode::kJointRelPosition;
  Rig relative(config);
  const EpisodeRecord r = *relative.runner->Run(0).record;
  ASSERT_EQ(NumSteps(a), NumSteps(r));  // the same episode: the mode only changes the record
  const size_t k = 10;
  const std::vector<double>& cmd = a.actions.at("commanded_action")[k].at("arm");
  const std::vector<double>& delta = r.actions.at("commanded_action")[k].at("arm");
  const std::vector<double>& q_prev = a.qpos[k - 1].at("arm");
  for (size_t i = 0; i < 7; ++i) EXPECT_NEAR(delta[i], cmd[i] - q_prev[i], 1e-12);
  // float32 (the default) rounds the commanded values.
  Rig f32(TutorialConfig());
  const EpisodeRecord f = *f32.runner->Run(0).record;
  for (size_t i = 0; i < 7; ++i) {
    const double v = f.actions.at("commanded_action")[k].at("arm")[i];
    EXPECT_EQ(v, static_cast<double>(static_cast<float>(cmd[i])));
  }
}

TEST(EpisodeRunnerTest, HorizonTruncatesAsTimeout) {
  ExperimentConfig config = TutorialConfig();
  config.task_horizon = 10;
  Rig rig(config);
  const EpisodeResult r = rig.runner->Run(0);
  EXPECT_EQ(r.attempt.outcome, Outcome::kTimeout);
  EXPECT_FALSE(r.success);
  ASSERT_TRUE(r.record.has_value());
  EXPECT_EQ(NumSteps(*r.record), 11u);
  EXPECT_TRUE(r.record->truncated.back());
  EXPECT_FALSE(r.record->terminated.back());
  EXPECT_THAT(r.attempt.message, HasSubstr("horizon"));
}

TEST(EpisodeRunnerTest, GraspsFromAnotherLibraryAreNoGrasp) {
  ExperimentConfig config = TutorialConfig();
  config.policy_config.grasp_libraries = std::vector<std::string>{"no_such_library"};
  Rig rig(config);
  const EpisodeResult r = rig.runner->Run(0);
  EXPECT_EQ(r.attempt.outcome, Outcome::kNoGrasp);
  EXPECT_THAT(r.attempt.message, HasSubstr("red_block"));
  EXPECT_FALSE(r.record.has_value());
}

// A user sampler that rejects every task, and one that forgets a field.
class RejectingSampler : public TaskSampler {
 public:
  using TaskSampler::TaskSampler;

 protected:
  void SampleAndPlaceRobot(Env&, Rng&, TaskDraft&) override {
    throw TaskRejected("no room for the robot");
  }
};

class ForgetfulSampler : public TaskSampler {
 public:
  using TaskSampler::TaskSampler;

 protected:
  void SampleAndPlaceRobot(Env& env, Rng&, TaskDraft& draft) override {
    draft.robot_base_pose = env.GetRobotBasePose();
    draft.pickup_obj_start_pose = env.GetBodyPose("red_block");
  }
};

TEST(EpisodeRunnerTest, RejectedTasksAreJournaledAndForgottenFieldsAreErrors) {
  TaskSamplerRegistry samplers;
  samplers.Register("rejecting", [](const ExperimentConfig& c, uint64_t s) {
    return std::make_unique<RejectingSampler>(c, s);
  });
  samplers.Register("forgetful", [](const ExperimentConfig& c, uint64_t s) {
    return std::make_unique<ForgetfulSampler>(c, s);
  });
  ExperimentConfig config = TutorialConfig();
  config.task_sampler_config.task_sampler_class = "rejecting";
  Rig rejecting(config, 3, samplers);
  const EpisodeResult r = rejecting.runner->Run(0);
  EXPECT_EQ(r.attempt.outcome, Outcome::kSamplerReject);
  EXPECT_THAT(r.attempt.message, HasSubstr("no room for the robot"));

  config.task_sampler_config.task_sampler_class = "forgetful";
  Rig forgetful(config, 3, samplers);
  testing::ExpectError([&] { forgetful.runner->Run(0); }, {"forgetful", "pickup_obj_goal_pose"});
}

TEST(EpisodeRunnerTest, MismatchedTimeStepsAreErrors) {
  ExperimentConfig config = TutorialConfig();
  config.sim_dt_ms = 3.0;
  config.ctrl_dt_ms = 3.0;
  testing::ExpectError([&] { Rig rig(config); }, {"sim_dt_ms", "timestep is 2"});
}

}  // namespace
}  // namespace mlspaces::datagen
