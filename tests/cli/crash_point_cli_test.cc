// Crash points (mlspaces/core/crash_point.h) as the kill tests use them, through the CLI:
// counting, killing after exactly step N, and malformed settings.
#include <algorithm>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::CopyExampleLibrary;
using ::mlspaces::testing::CrashPoints;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;

TEST(CrashPointCli, CountsStepsAndKillsAfterExactlyStepN) {
  TempDir dir;
  const fs::path library = CopyExampleLibrary(dir.path());
  const CrashPoints crash(dir / "counter");
  const std::vector<std::string> args = {"index-assets", library.string(), "--overwrite"};
  const auto counted = RunCli(args, crash.Counting());
  ASSERT_EQ(counted.exit_code, 0) << counted.err;
  const uint64_t steps = crash.Count();
  ASSERT_GE(steps, 2u);  // the index: its temp file written, then renamed into place
  ASSERT_EQ(RunCli(args, crash.Counting()).exit_code, 0);
  EXPECT_EQ(crash.Count(), steps) << "the same work counts the same steps";

  for (uint64_t n = 1; n <= steps; ++n) {
    const auto cut = RunCli(args, crash.KillAt(n));
    EXPECT_TRUE(cut.sigkilled) << "step " << n << ": exit " << cut.exit_code << " " << cut.err;
    EXPECT_THAT(cut.err, HasSubstr("mlspaces: crash point " + std::to_string(n) + " ("));
    EXPECT_EQ(crash.Count(), n) << "the kill comes right after step " << n;
  }
  // One past the last step: the run completes.
  const auto past = RunCli(args, crash.KillAt(steps + 1));
  EXPECT_EQ(past.exit_code, 0) << past.err;
  EXPECT_FALSE(past.sigkilled);
  EXPECT_EQ(crash.Count(), steps);
}

TEST(CrashPointCli, MalformedSettingsAreOneLineErrors) {
  TempDir dir;
  const fs::path library = CopyExampleLibrary(dir.path());
  for (const std::string bad : {"abc", "0", "-1", "3x", "99999999999999999999999"}) {
    const auto r = RunCli({"validate", library.string()}, "env MLSPACES_CRASH_AT=" + bad + " ");
    EXPECT_EQ(r.exit_code, 1) << bad;
    EXPECT_THAT(r.err, HasSubstr("MLSPACES_CRASH_AT")) << bad;
    EXPECT_THAT(r.err, HasSubstr("'" + bad + "'"));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  const auto r = RunCli({"validate", library.string()},
                        "env MLSPACES_CRASH_COUNTER=" + (dir / "no/such/dir/c").string() + " ");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr((dir / "no/such/dir/c").string()));
  EXPECT_THAT(r.err, HasSubstr("crash counter"));
  // Empty means unset, as for every MLSPACES_* variable.
  EXPECT_EQ(RunCli({"validate", library.string()}, "env MLSPACES_CRASH_AT= ").exit_code, 0);
}

}  // namespace
}  // namespace mlspaces
