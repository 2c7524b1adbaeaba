#include "mlspaces/datagen/run.h"

#include <filesystem>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

ExperimentConfig Tutorial(const fs::path& output, int64_t episodes, uint64_t seed = 5) {
  ExperimentConfig c = LoadConfigFile(kExample / "datagen.yaml", ConfigRegistry::WithBuiltins());
  c.output_dir = output;
  c.seed = seed;
  c.task_sampler_config.samples_per_house = episodes;
  return c;
}

std::vector<int64_t> BatchSizes(int64_t samples, int64_t per_batch) {
  ExperimentConfig c;
  c.task_sampler_config.scene_xml_paths = {"a.xml", "b.xml"};
  c.task_sampler_config.house_inds = std::vector<int64_t>{1};
  c.task_sampler_config.samples_per_house = samples;
  c.task_sampler_config.episodes_per_batch = per_batch;
  std::vector<int64_t> sizes;
  for (const WorkItem& w : PlanWorkItems(c)) {
    EXPECT_EQ(w.house, 1);
    EXPECT_EQ(w.scene_xml, "b.xml");
    EXPECT_EQ(w.max_attempts, w.episodes * c.task_sampler_config.max_total_attempts_multiplier);
    sizes.push_back(w.episodes);
  }
  return sizes;
}

TEST(PlanWorkItemsTest, BatchesRoundHalfToEvenAndSplitEvenly) {
  EXPECT_EQ(BatchSizes(2, 4), (std::vector<int64_t>{2}));        // round(0.5) = 0 -> 1 batch
  EXPECT_EQ(BatchSizes(6, 4), (std::vector<int64_t>{3, 3}));     // round(1.5) = 2
  EXPECT_EQ(BatchSizes(10, 4), (std::vector<int64_t>{5, 5}));    // round(2.5) = 2
  EXPECT_EQ(BatchSizes(7, 2), (std::vector<int64_t>{2, 2, 2, 1}));  // round(3.5) = 4
  EXPECT_EQ(BatchSizes(9, 4), (std::vector<int64_t>{5, 4}));
}

TEST(PlanWorkItemsTest, EpisodeNumbersDoNotOverlapAcrossBatches) {
  ExperimentConfig c;
  c.task_sampler_config.scene_xml_paths = {"a.xml", "b.xml"};
  c.task_sampler_config.samples_per_house = 8;
  c.task_sampler_config.episodes_per_batch = 4;
  const std::vector<WorkItem> items = PlanWorkItems(c);
  ASSERT_EQ(items.size(), 4u);
  EXPECT_EQ(items[0].scene_name(), "house_0");
  EXPECT_EQ(items[1].first_episode, items[0].first_episode + items[0].max_attempts);
  EXPECT_EQ(items[2].scene_name(), "house_1");
  EXPECT_EQ(items[2].first_episode, 0);
  c.task_sampler_config.house_inds = std::vector<int64_t>{2};
  testing::ExpectError([&] { PlanWorkItems(c); }, {"house_inds", "out of range"});
}

TEST(RunDatagenTest, WritesTrajectoriesJournalSummaryAndConfig) {
  testing::TempDir dir;
  const RunReport report = RunDatagen(Tutorial(dir / "run", 3), TaskSamplerRegistry::WithBuiltins());
  EXPECT_EQ(report.episodes_kept, 3);
  EXPECT_EQ(report.seed, 5u);
  EXPECT_EQ(report.summary.count(Outcome::kSuccess), 3);
  ASSERT_EQ(report.batch_files.size(), 1u);
  EXPECT_EQ(report.batch_files[0], dir / "run/house_0/trajectories_batch_1_of_1.h5");
  EXPECT_TRUE(fs::is_regular_file(report.batch_files[0]));
  EXPECT_FALSE(fs::exists(dir / "run/house_0/trajectories_batch_1_of_1.parts"));
  EXPECT_EQ(ReadJournal(dir / "run/journal.jsonl").records.size(), 3u);
  EXPECT_THAT(testing::Slurp(dir / "run/summary.txt"), HasSubstr("success"));
  // config.yaml reloads to the same config.
  const ExperimentConfig stored =
      LoadConfigFile(dir / "run/config.yaml", ConfigRegistry::WithBuiltins());
  EXPECT_EQ(ConfigHashHex(stored), ConfigHashHex(Tutorial(dir / "run", 3)));
  EXPECT_EQ(DataConfigHashHex(stored), DataConfigHashHex(Tutorial(dir / "elsewhere", 3)));
  // h5py reads it: three trajectories, each ending in success.
  testing::RunPython(dir.path(), R"(
import h5py, sys
f = h5py.File(sys.argv[1], "r")
assert sorted(f.keys()) == ["traj_0", "traj_1", "traj_2"], list(f.keys())
for k in f:
    assert f[k]["success"][-1] and f[k]["terminated"][-1]
    assert f[k]["obs/agent/qpos"].shape[0] == f[k]["actions/joint_pos"].shape[0]
)",
                     testing::ShellQuote(report.batch_files[0].string()));
  // A second invocation finds the work done.
  const RunReport again = RunDatagen(Tutorial(dir / "run", 3), TaskSamplerRegistry::WithBuiltins());
  EXPECT_EQ(again.items_skipped, 1);
  EXPECT_EQ(again.summary.attempts, 0);
}

TEST(RunDatagenTest, SameConfigAndSeedGiveIdenticalBytes) {
  testing::TempDir dir;
  RunDatagen(Tutorial(dir / "a", 2, 9), TaskSamplerRegistry::WithBuiltins());
  RunDatagen(Tutorial(dir / "b", 2, 9), TaskSamplerRegistry::WithBuiltins());
  const std::string a = testing::Slurp(dir / "a/house_0/trajectories_batch_1_of_1.h5");
  EXPECT_FALSE(a.empty());
  // (EXPECT_TRUE: a failing EXPECT_EQ would print megabytes.)
  EXPECT_TRUE(a == testing::Slurp(dir / "b/house_0/trajectories_batch_1_of_1.h5"));
}

TEST(RunDatagenTest, InterruptedRunResumesToTheSameBytes) {
  testing::TempDir dir;
  RunDatagen(Tutorial(dir / "whole", 4), TaskSamplerRegistry::WithBuiltins());
  // Stop after the second attempt, as a crash between episodes would.
  RunOptions stop;
  int attempts = 0;
  stop.on_attempt = [&](const WorkItem&, const AttemptRecord&) {
    if (++attempts == 2) throw std::runtime_error("interrupted");
  };
  EXPECT_THROW(RunDatagen(Tutorial(dir / "cut", 4), TaskSamplerRegistry::WithBuiltins(), stop),
               std::runtime_error);
  EXPECT_FALSE(fs::exists(dir / "cut/house_0/trajectories_batch_1_of_1.h5"));
  const RunReport resumed = RunDatagen(Tutorial(dir / "cut", 4), TaskSamplerRegistry::WithBuiltins());
  EXPECT_EQ(resumed.summary.attempts, 2);  // only the missing ones ran
  EXPECT_TRUE(testing::Slurp(dir / "cut/house_0/trajectories_batch_1_of_1.h5") ==
              testing::Slurp(dir / "whole/house_0/trajectories_batch_1_of_1.h5"));
  EXPECT_EQ(ReadJournal(dir / "cut/journal.jsonl").records.size(), 4u);
}

TEST(RunDatagenTest, FolderOfAnotherConfigIsRefusedAndNullSeedIsReused) {
  testing::TempDir dir;
  ExperimentConfig first = Tutorial(dir / "run", 1);
  first.seed.reset();
  const RunReport a = RunDatagen(first, TaskSamplerRegistry::WithBuiltins());
  // A null seed was drawn and stored; running the same config again reuses it.
  const RunReport b = RunDatagen(first, TaskSamplerRegistry::WithBuiltins());
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(b.items_skipped, 1);
  ExperimentConfig other = Tutorial(dir / "run", 2);
  testing::ExpectError([&] { RunDatagen(other, TaskSamplerRegistry::WithBuiltins()); },
                       {"config.yaml", "another config", "another output folder"});
}

TEST(DatagenCliTest, GeneratesTheTutorialData) {
  testing::TempDir dir;
  const testing::CliResult r = testing::RunCli(
      {"datagen", (kExample / "datagen.yaml").string(), "--output", (dir / "out").string(),
       "--episodes", "2", "--seed", "3"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("episodes kept: 2"));
  EXPECT_THAT(r.out, HasSubstr("success rate: 100.0%"));
  EXPECT_THAT(r.err, HasSubstr("wrote "));
  EXPECT_TRUE(fs::is_regular_file(dir / "out/house_0/trajectories_batch_1_of_1.h5"));
  // -q: nothing on stderr.
  const testing::CliResult quiet = testing::RunCli(
      {"datagen", (kExample / "datagen.yaml").string(), "--output", (dir / "q").string(),
       "--episodes", "1", "--seed", "3", "-q"});
  EXPECT_EQ(quiet.exit_code, 0);
  EXPECT_EQ(quiet.err, "");
}

TEST(DatagenCliTest, BadInputGetsOneLineAndAnExitCode) {
  testing::TempDir dir;
  const std::string yaml = (kExample / "datagen.yaml").string();
  struct Case {
    std::vector<std::string> args;
    int code;
    std::string says;
  };
  const std::vector<Case> cases = {
      {{"datagen", (dir / "missing.yaml").string()}, 1, "missing.yaml"},
      {{"datagen", yaml, "--set", "policy_config.speed_fats=1"}, 2, "speed_fats"},
      {{"datagen", yaml, "--episodes", "0"}, 2, "--episodes"},
      {{"datagen", yaml, "--seed", "-1"}, 2, "--seed"},
      {{"datagen", yaml, "--output", (dir / "o").string(), "--set", "robot_config.name=ur5"},
       1,
       "robot_config.name"},
  };
  for (const Case& c : cases) {
    const testing::CliResult r = testing::RunCli(c.args);
    EXPECT_EQ(r.exit_code, c.code) << c.args.back() << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.says));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

}  // namespace
}  // namespace mlspaces::datagen
