// Open / close tasks (docs/tasks.md): success rule, config errors, and real runs of the
// example (examples/open_close) in MuJoCo: episodes succeed, validate, record the joint, and
// are the same bytes with 1 or 2 workers and after a resume.
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "datagen/tasks/task_run_checks.h"
#include "mlspaces/core/error.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/dataset_validate.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/datagen/tasks/open_close/planner.h"
#include "mlspaces/datagen/tasks/open_close/sampler.h"
#include "mlspaces/datagen/tasks/open_close/success.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "open_close";
const fs::path kCabinet =
    fs::path(MLSPACES_EXAMPLES_DIR) / "objects" / "cabinet_drawer_door" / "cabinet_drawer_door.xml";

ExperimentConfig Example(const std::string& task, const fs::path& output, int64_t episodes,
                         uint64_t seed) {
  ExperimentConfig c =
      LoadConfigFile(kExample / ("datagen_" + task + ".yaml"), ConfigRegistry::WithBuiltins());
  c.output_dir = output;
  c.seed = seed;
  c.task_sampler_config.samples_per_house = episodes;
  c.task_config.enable_rendering = false;
  return c;
}

TEST(OpenCloseSuccessTest, FractionRewardThresholdAndDescription) {
  TaskJoint slide{"s", "s", 0.0, 0.25, 0.0, 0.25, 0.0};
  EXPECT_DOUBLE_EQ(OpenedFraction(slide, 0.125), 0.5);
  EXPECT_DOUBLE_EQ(OpenedFraction(slide, 0.3), 1.0);  // clamped
  // A two-sided range (the original assumes one limit is 0): closed = the limit nearest 0.
  TaskJoint hinge{"h", "h", -1.5, 0.1, 0.1, -1.5, 0.1};
  EXPECT_DOUBLE_EQ(OpenedFraction(hinge, 0.1), 0.0);
  EXPECT_DOUBLE_EQ(OpenedFraction(hinge, -0.7), 0.5);

  char error[1000] = "";
  mjModel* m = mj_loadXML(kCabinet.c_str(), nullptr, error, sizeof error);
  ASSERT_NE(m, nullptr) << error;
  mjData* d = mj_makeData(m);
  const int j = mj_name2id(m, mjOBJ_JOINT, "drawer_slide");
  d->qpos[m->jnt_qposadr[j]] = 0.2;
  const OpenCloseVerdict open = EvaluateOpenClose(m, d, j, slide, TaskType::kOpen, 0.15);
  EXPECT_NEAR(open.opened_fraction, 0.8, 1e-12);
  EXPECT_NEAR(open.reward, 0.8, 1e-12);
  EXPECT_TRUE(open.success);
  const OpenCloseVerdict close = EvaluateOpenClose(m, d, j, slide, TaskType::kClose, 0.85);
  EXPECT_NEAR(close.reward, 0.2, 1e-12);
  EXPECT_FALSE(close.success);
  EXPECT_THROW(EvaluateOpenClose(m, d, j, slide, TaskType::kPick, 0.5), UsageError);
  mj_deleteData(d);
  mj_deleteModel(m);

  ExperimentConfig c;
  c.task_type = TaskType::kClose;
  EXPECT_DOUBLE_EQ(OpenCloseThreshold(c), 0.85);
  c.task_type = TaskType::kOpen;
  EXPECT_DOUBLE_EQ(OpenCloseThreshold(c), 0.15);
  c.task_config.task_success_threshold = 0.5;
  EXPECT_DOUBLE_EQ(OpenCloseThreshold(c), 0.5);
  // The original describes both tasks as "Open the ...".
  EXPECT_EQ(OpenCloseDescription(TaskType::kClose, "cabinet", "drawer"),
            "Close the drawer of the cabinet");
  EXPECT_EQ(OpenCloseDescription(TaskType::kOpen, "cabinet", ""), "Open the cabinet");
}

TEST(OpenCloseConfigTest, BadTaskFieldsGetOneLineNamingFileAndField) {
  testing::TempDir dir;
  const std::string base = testing::Slurp(kExample / "datagen_open.yaml");
  // The example's config in a temp folder, its relative paths made absolute.
  auto load = [&](std::string text) {
    for (const auto& [rel, abs] :
         {std::pair<std::string, fs::path>{"[scene.xml]", kExample / "scene.xml"},
          {"path: ../objects", kExample / "../objects"}}) {
      for (size_t at = text.find(rel); at != std::string::npos; at = text.find(rel, at + 1)) {
        const std::string to = rel[0] == '[' ? "[" + abs.string() + "]" : "path: " + abs.string();
        text.replace(at, rel.size(), to);
      }
    }
    testing::WriteText(dir / "bad.yaml", text);
    ExperimentConfig c = LoadConfigFile(dir / "bad.yaml", ConfigRegistry::WithBuiltins());
    Validate(c, dir / "bad.yaml");  // as `mlspaces datagen` does
    return c;
  };
  EXPECT_NO_THROW(load(base));
  auto with = [&](const std::string& from, const std::string& to) {
    std::string text = base;
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    return text;
  };
  const std::string file = (dir / "bad.yaml").string();
  testing::ExpectError(
      [&] { load(with("task_success_threshold: 0.15", "task_success_threshold: 1.5")); },
      {file, "task_config.task_success_threshold", "(0, 1]"});
  testing::ExpectError(
      [&] {
        load(with("target_initial_state_open_percentage: 0.0",
                  "target_initial_state_open_percentage: -0.5"));
      },
      {file, "task_sampler_config.target_initial_state_open_percentage"});
  testing::ExpectError(
      [&] {
        load(with("task_sampler_class: OpenTaskSampler", "task_sampler_class: block_pickup"));
      },
      {file, "task_sampler_config.task_sampler_class", "OpenTaskSampler"});
  testing::ExpectError([&] { load(with("task_type: open", "task_type: opne")); },
                       {file, "task_type"});
}

// A few episodes of each task, seeds fixed: every one succeeds, the dataset validates, and
// the chosen joint is recorded.
TEST(OpenCloseRunTest, OpenAndCloseEpisodesSucceedAndValidate) {
  testing::TempDir dir;
  for (const std::string task : {"open", "close"}) {
    const RunReport r =
        RunDatagen(Example(task, dir / task, 3, 1), TaskSamplerRegistry::WithBuiltins());
    EXPECT_EQ(r.episodes_kept, 3) << task;
    EXPECT_EQ(r.summary.count(Outcome::kSuccess), r.summary.attempts) << task;
    const DatasetReport v = ValidateDataset(dir / task);
    EXPECT_TRUE(v.ok()) << task;
    EXPECT_EQ(v.trajectories, 3) << task;
    const std::string journal = testing::Slurp(dir / task / "journal.jsonl");
    EXPECT_THAT(journal, HasSubstr("\"opened_fraction\""));
    EXPECT_THAT(journal, HasSubstr("\"joint\":\"door_hinge\""));  // both joints, this seed
    EXPECT_THAT(journal, HasSubstr("\"joint\":\"drawer_slide\""));
  }
}

// The xArm7 on the door (docs/tasks.md, "Figures"): its gripper's pads slide straight, so
// only grasps that hold the handle between the open pads are taken, and a door half open
// toward it would reach into its hand at home, so the hand starts drawn back. Every
// attempt on the door succeeds, opening and closing, for this seed.
TEST(OpenCloseRunTest, Xarm7OpensAndClosesTheDoor) {
  testing::TempDir dir;
  for (const std::string task : {"open", "close"}) {
    ExperimentConfig c = Example(task, dir / task, 3, 3);
    c.robot_config.name = "xarm7";
    c.task_config.joint_name = "door_hinge";
    const RunReport r = RunDatagen(c, TaskSamplerRegistry::WithBuiltins());
    EXPECT_EQ(r.episodes_kept, 3) << task;
    EXPECT_EQ(r.summary.count(Outcome::kSuccess), r.summary.attempts) << task;
  }
}

TEST(OpenCloseRunTest, WorkersShardsAndResumeGiveTheSameBytes) {
  testing::TempDir dir;
  auto config = [&](const std::string& name) {
    ExperimentConfig c = Example("close", dir / name, 2, 4);
    c.task_sampler_config.episodes_per_batch = 1;
    return c;
  };
  testing::ExpectWorkersShardsAndResumeGiveTheSameBytes(config, dir.path(), 2);
}

}  // namespace
}  // namespace mlspaces::datagen
