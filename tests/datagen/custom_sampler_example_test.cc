// Runs examples/custom_assets/custom_sampler.cc (custom_sampler_example): a TaskSampler
// subclass registered as "my_block_pickup" and used by a datagen run of the tutorial config.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace mlspaces::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;

const fs::path kConfig = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "datagen.yaml";

// Runs the example with `args`.
CliResult RunExample(const std::vector<std::string>& args) {
  return RunProgram(MLSPACES_EXAMPLE_SAMPLER_PATH, args);
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// The tutorial folder copied, its config with cheap cameras (shadow maps and the reflection
// pass are nearly all of a frame's cost; this test is about the sampler, not the pictures).
fs::path CheapCameraConfig(const fs::path& tmp) {
  const fs::path dst = tmp / "custom_assets";
  fs::copy(kConfig.parent_path(), dst, fs::copy_options::recursive);
  std::string yaml = Slurp(dst / "datagen.yaml");
  const std::string key = "  img_resolution: [640, 368]\n";
  const size_t at = yaml.find(key);
  EXPECT_NE(at, std::string::npos);
  yaml.replace(at, key.size(),
               "  img_resolution: [128, 80]\n  shadows: false\n  reflections: false\n");
  WriteText(dst / "datagen.yaml", yaml);
  return dst / "datagen.yaml";
}

TEST(CustomSamplerExampleTest, RunsDatagenWithTheRegisteredSampler) {
  TempDir tmp;
  const fs::path run = tmp / "run";
  const CliResult r = RunExample({CheapCameraConfig(tmp.path()).string(), run.string(), "2"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("episodes kept: "));
  EXPECT_TRUE(fs::is_regular_file(run / "house_0" / "trajectories_batch_1_of_1.h5"))
      << ::testing::PrintToString(ListFiles(run));
  // One journal line per attempt, at least one per kept episode.
  const std::vector<std::string> journal = Lines(Slurp(run / "journal.jsonl"));
  EXPECT_GE(journal.size(), 1u);
  for (const std::string& line : journal) EXPECT_THAT(line, StartsWith("{"));
  // The run's resolved config names our sampler and the episode count.
  const std::string config = Slurp(run / "config.yaml");
  EXPECT_THAT(config, HasSubstr("task_sampler_class: my_block_pickup"));
  EXPECT_THAT(config, HasSubstr("samples_per_house: 2"));
  EXPECT_THAT(config, HasSubstr("output_dir: " + run.string()));
}

TEST(CustomSamplerExampleTest, BadConfigPathIsOneLineAndExit1) {
  TempDir tmp;
  const CliResult r = RunExample({(tmp / "missing.yaml").string(), (tmp / "run").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  const std::vector<std::string> lines = Lines(r.err);
  ASSERT_EQ(lines.size(), 1u) << r.err;
  EXPECT_THAT(lines[0], StartsWith("custom_sampler: error: "));
  EXPECT_THAT(lines[0], HasSubstr("missing.yaml"));
  EXPECT_FALSE(fs::exists(tmp / "run"));
}

TEST(CustomSamplerExampleTest, BadEpisodeCountIsExit1) {
  TempDir tmp;
  const CliResult r = RunExample({kConfig.string(), (tmp / "run").string(), "two"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("custom_sampler: error: EPISODES must be a positive integer"));
  EXPECT_FALSE(fs::exists(tmp / "run"));
}

TEST(CustomSamplerExampleTest, NoArgumentsIsUsageExit2) {
  const CliResult r = RunExample({});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, StartsWith("usage: custom_sampler_example CONFIG.yaml"));
}

}  // namespace
}  // namespace mlspaces::testing
