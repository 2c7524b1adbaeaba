#include "mlspaces/datagen/tasks/task_family.h"

#include <filesystem>
#include <memory>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/episode_runner.h"
#include "mlspaces/datagen/eval_env.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

const std::filesystem::path kExample =
    std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

ExperimentConfig TutorialConfig() {
  return LoadConfigFile(kExample / "datagen.yaml", ConfigRegistry::WithBuiltins());
}

TEST(TaskFamilyTest, EveryTaskTypeHasItsFamily) {
  const std::string expected[] = {"pick",           "open_close",     "open_close",
                                  "pick_and_place", "pick_and_place", "pick_and_place"};
  ASSERT_EQ(std::size(expected), EnumNames<TaskType>::kNames.size());
  for (size_t i = 0; i < std::size(expected); ++i) {
    const auto type = static_cast<TaskType>(i);
    SCOPED_TRACE(EnumName(type));
    const TaskFamily& family = TaskFamilyOf(type);
    EXPECT_EQ(family.name, expected[i]);
    EXPECT_TRUE(family.has_type(type));
    ASSERT_NE(family.make_planner, nullptr);
    ASSERT_NE(family.make_episode, nullptr);
    ASSERT_NE(family.sampler_refusal, nullptr);
    ASSERT_NE(family.owns_sampler, nullptr);
    // The type belongs to no other family.
    for (const TaskFamily* other : TaskFamilies()) {
      EXPECT_EQ(other->has_type(type), other == &family) << other->name;
    }
  }
  EXPECT_EQ(TaskFamilies().size(), 3u);
  testing::ExpectError([] { TaskFamilyOf(static_cast<TaskType>(99)); },
                       {"task_type 99", "no task family"});
}

TEST(TaskFamilyTest, ReferralIsTheCategoryElseTheBodyName) {
  Annotation with_category;
  with_category.json = Json{{"category", "coffee mug"}};
  EXPECT_EQ(Referral("mug_1", &with_category), "coffee mug");
  Annotation empty_category;
  empty_category.json = Json{{"category", ""}};
  EXPECT_EQ(Referral("red_block", &empty_category), "red block");
  EXPECT_EQ(Referral("red_block", nullptr), "red block");
}

// Which samplers may draw which task types, as the families say: a family's own sampler with
// another family's type, or a sampler that cannot choose what the family needs, is one error
// naming the field; any other pairing passes.
TEST(TaskFamilyTest, ConfigsPairTaskTypesWithTheirFamiliesSamplers) {
  struct Case {
    TaskType type;
    std::string sampler, error;  // error "": valid
  };
  for (const Case& c : {
           Case{TaskType::kPick, "block_pickup", ""},
           Case{TaskType::kPick, "my_sampler", ""},
           Case{TaskType::kOpen, "OpenTaskSampler", ""},
           Case{TaskType::kClose, "opentasksampler", ""},
           Case{TaskType::kOpen, "my_sampler", ""},
           Case{TaskType::kPickAndPlaceColor, "PickAndPlaceColorTaskSampler", ""},
           Case{TaskType::kPick, "OpenTaskSampler", "OpenTaskSampler samples open_close tasks"},
           Case{TaskType::kPick, "PickAndPlaceTaskSampler",
                "PickAndPlaceTaskSampler samples pick_and_place tasks; task_type is pick"},
           Case{TaskType::kOpen, "block_pickup", "needs a sampler that chooses a joint"},
           Case{TaskType::kClose, "PickAndPlaceTaskSampler", "samples pick_and_place tasks"},
           Case{TaskType::kPickAndPlace, "block_pickup", "needs a sampler that chooses a place"},
           Case{TaskType::kPickAndPlaceNextTo, "OpenTaskSampler",
                "a place target (PickAndPlaceTaskSampler, PickAndPlaceNextToTaskSampler, "
                "PickAndPlaceColorTaskSampler), not OpenTaskSampler"},
       }) {
    SCOPED_TRACE(std::string(EnumName(c.type)) + " " + c.sampler);
    ExperimentConfig config = TutorialConfig();
    config.task_type = c.type;
    config.task_sampler_config.task_sampler_class = c.sampler;
    if (c.error.empty()) {
      EXPECT_NO_THROW(Validate(config, "c.yaml"));
    } else {
      testing::ExpectError([&] { Validate(config, "c.yaml"); },
                           {"c.yaml", "task_sampler_config.task_sampler_class", c.error});
    }
  }
}

// A pick sampler asked for a task type whose family needs more than a pick task: a joint
// (open / close) or a place target (pick_and_place*). The runner and the gym env say which
// sampler and what is missing, and the env is left unstarted.
TEST(TaskFamilyTest, ATaskWithoutWhatItsFamilyNeedsIsAnError) {
  struct Case {
    TaskType type;
    std::string missing;
  };
  for (const Case& c : {Case{TaskType::kOpen, "chose no joint"},
                        Case{TaskType::kPickAndPlace, "chose no place target"}}) {
    SCOPED_TRACE(c.missing);
    ExperimentConfig config = TutorialConfig();
    config.task_type = c.type;  // the sampler stays block_pickup (validation would refuse it)
    Env env = Env::Create(sim::Scene::Load(kExample / "scene.xml"),
                          RobotSpecFromConfig(config.robot_config), "house_0");
    Registry registry;
    config.libraries.ApplyTo(registry);
    const std::unique_ptr<TaskSampler> sampler =
        TaskSamplerRegistry::WithBuiltins().Create(config, 3);
    EpisodeRunner runner(env, *sampler, registry, config);
    testing::ExpectError([&] { runner.Run(0); },
                         {"task sampler 'block_pickup'", c.missing, "task_sampler_class"});

    EvalEnv eval(config, TaskSamplerRegistry::WithBuiltins().Create(config, 3),
                 EvalEnvOptions{.render = false});
    testing::ExpectError([&] { eval.Reset(3, 0, 0); }, {"block_pickup", c.missing});
    EXPECT_FALSE(eval.started());
    testing::ExpectError([&] { eval.Step(std::vector<double>(7, 0.0), 0); }, {"reset first"});
  }
}

// Each family's episode on the first state of an example's first task (nothing has moved:
// no family's success), judged and described as the runner does at the end of an episode
// whose plan ran out without success.
TEST(TaskFamilyTest, EachFamilyJudgesDescribesAndExplainsAFailure) {
  struct Case {
    std::string config;
    std::string failure, description, scene_key;
  };
  const std::filesystem::path examples(MLSPACES_EXAMPLES_DIR);
  for (const Case& c : {
           Case{"custom_assets/datagen.yaml", "the object is not held: lift 0.0",
                "Pick up the thing", "frozen_config"},
           Case{"open_close/datagen_open.yaml", "at opened fraction 0.0", "Open the ", "joint"},
           Case{"open_close/datagen_close.yaml", "at opened fraction", "Close the ", "joint"},
           Case{"pick_and_place/datagen.yaml", "the object is not placed: {",
                "Pick up the thing and place it in or on the ", "place_receptacle_name"},
           Case{"pick_and_place/datagen_next_to.yaml", "the object is not placed: {",
                "Pick up the thing and place it next to the ", "place_receptacle_name"},
           Case{"pick_and_place/datagen_color.yaml", "the object is not placed: {",
                "Pick up the thing and place it in or on the ", "place_receptacle_name"},
       }) {
    SCOPED_TRACE(c.config);
    const ExperimentConfig config =
        LoadConfigFile(examples / c.config, ConfigRegistry::WithBuiltins());
    Registry registry;
    config.libraries.ApplyTo(registry);
    EvalEnv eval(config, TaskSamplerRegistry::WithBuiltins().Create(config, 3),
                 EvalEnvOptions{.render = false});
    eval.Reset(3, 0, 0);
    const Env& env = eval.env();
    std::unique_ptr<TaskEpisode> episode =
        TaskFamilyOf(config.task_type).make_episode(env, config, eval.task(), "test");
    EXPECT_EQ(episode->object(), env.BodyId(eval.task().pickup_obj_name));

    PickSuccess verdict =
        EvaluatePickSuccess(env.model(), env.data(), episode->object(),
                            eval.task().pickup_obj_start_pose.pos[2], env.robot().prefix);
    episode->Judge(env.data(), verdict);
    EXPECT_FALSE(verdict.success);
    EXPECT_EQ(verdict.success, eval.verdict().success);
    EXPECT_EQ(verdict.reward, eval.verdict().reward);
    EXPECT_THAT(episode->FailureMessage(verdict, 0), HasSubstr(c.failure));
    EXPECT_THAT(episode->Description(registry, "thing"), StartsWith(c.description));

    EpisodeRecord rec;
    episode->DeclareSeries(rec);
    episode->Record(rec, env.data(), 0, verdict);
    ASSERT_EQ(rec.extra_json["task_info"].steps.size(), 1u);
    const Json& info = rec.extra_json["task_info"].steps[0];
    EXPECT_EQ(info.value("success", true), false) << info.dump();
    Json obs_scene{{"frozen_config", Json::object()}};
    episode->AddToObsScene(registry, "thing", obs_scene);
    EXPECT_TRUE(obs_scene.contains(c.scene_key)) << obs_scene.dump();
  }
}

}  // namespace
}  // namespace mlspaces::datagen
