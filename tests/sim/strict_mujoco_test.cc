// The strict MuJoCo main itself (tests/strict_mujoco_main.cc): a warning left behind fails the
// test that left it; ExpectMujocoWarning consumes an expected one and fails on a missing one.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "strict_mujoco.h"
#include "test_util.h"

namespace mlspaces::testing {
namespace {

TEST(StrictMujoco, ExpectMujocoWarningConsumesTheWarning) {
  mju_warning("strict fixture probe %d", 7);
  const auto warnings = ExpectMujocoWarning("strict fixture probe 7");
  EXPECT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(sim::TakeMujocoWarnings().empty());
}

// Run only by the test below, in a child process: it must fail.
TEST(StrictMujoco, DISABLED_LeavesAWarning) { mju_warning("left behind on purpose"); }
TEST(StrictMujoco, DISABLED_ExpectsAWarningThatNeverCame) { ExpectMujocoWarning("never"); }

TEST(StrictMujoco, AWarningLeftBehindOrMissingFailsTheTest) {
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
  for (const char* name : {"DISABLED_LeavesAWarning", "DISABLED_ExpectsAWarningThatNeverCame"}) {
    const CliResult r = RunProgram(self, {"--gtest_also_run_disabled_tests",
                                          std::string("--gtest_filter=StrictMujoco.") + name});
    EXPECT_NE(r.exit_code, 0) << name << "\n" << r.out + r.err;
  }
  const CliResult left = RunProgram(self, {"--gtest_also_run_disabled_tests",
                                           "--gtest_filter=StrictMujoco.DISABLED_LeavesAWarning"});
  EXPECT_NE((left.out + left.err).find("left 1 unexpected MuJoCo warning(s):"), std::string::npos)
      << left.out;
  EXPECT_NE((left.out + left.err).find("left behind on purpose"), std::string::npos) << left.out;
}

}  // namespace
}  // namespace mlspaces::testing
