// gtest main of the sim and datagen suites: see strict_mujoco.h.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/sim/mujoco_handlers.h"

namespace {

/// After each test: a MuJoCo warning still collected on the main thread is a failure (a test
/// that expects one consumes it with ExpectMujocoWarning).
class StrictMujocoListener : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo&) override {
    mlspaces::sim::TakeMujocoWarnings();  // nothing from an earlier test counts against this one
  }
  void OnTestEnd(const ::testing::TestInfo& info) override {
    const std::vector<std::string> left = mlspaces::sim::TakeMujocoWarnings();
    if (left.empty()) return;
    std::string all;
    for (const std::string& w : left) all += "\n  " + w;
    ADD_FAILURE() << info.test_suite_name() << "." << info.name() << " left " << left.size()
                  << " unexpected MuJoCo warning(s):" << all;
  }
};

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  mlspaces::sim::InstallMujocoHandlers();
  ::testing::UnitTest::GetInstance()->listeners().Append(new StrictMujocoListener);
  return RUN_ALL_TESTS();
}
