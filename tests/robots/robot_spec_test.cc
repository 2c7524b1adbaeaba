// robot.yaml loading (robots/robot_spec.h): the bundled robots, strictness, name checks.
#include "mlspaces/robots/robot_spec.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "test_util.h"

namespace mlspaces::robots {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kFranka = fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid";

// A copy of franka_droid's folder whose robot.yaml has `from` replaced by `to`.
fs::path EditedFranka(const testing::TempDir& tmp, const std::string& from, const std::string& to) {
  fs::path dir = tmp.path() / "robot";
  fs::create_directories(dir);
  fs::copy_file(kFranka / "franka_droid.xml", dir / "franka_droid.xml",
                fs::copy_options::overwrite_existing);
  std::string text = testing::Slurp(kFranka / "robot.yaml");
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  testing::WriteText(dir / "robot.yaml", text);
  return dir;
}

TEST(RobotSpecTest, FrankaDroidLoadsAsData) {
  const RobotDescription d = LoadRobotDescription(kFranka);
  EXPECT_EQ(d.name, "franka_droid");
  EXPECT_EQ(d.file, fs::absolute(kFranka / "robot.yaml").lexically_normal());
  EXPECT_EQ(d.mjcf.filename(), "franka_droid.xml");
  EXPECT_EQ(d.arm.joints.size(), 7u);
  EXPECT_EQ(d.hash.size(), 16u);
  const RobotSpec s = MakeRobotSpec(d, "robot_0/");
  EXPECT_EQ(s.arm_actuators, s.arm_joints);
  EXPECT_EQ(s.articulation_name, "panda");
  EXPECT_EQ(s.articulation_width, 31u);
  EXPECT_TRUE(s.base_in_model);
  EXPECT_EQ(s.base_kind, BaseKind::kMocap);
  EXPECT_EQ(s.home_noise.size(), 7u);
  EXPECT_EQ(s.Resolve("fr3_link0"), "fr3_link0");
  EXPECT_THAT(BundledRobots(), ::testing::Contains("franka_droid"));
  // The MJCF's home numerics (for loading the file alone) mirror robot.yaml's home.
  const sim::ModelPtr m = sim::ComposeAndCompile(d.mjcf);
  for (const auto& [numeric, home] :
       {std::pair{"home_arm", d.arm.home}, std::pair{"home_gripper", d.gripper.home}}) {
    const int id = mj_name2id(m.get(), mjOBJ_NUMERIC, numeric);
    ASSERT_GE(id, 0) << numeric;
    const double* data = m->numeric_data + m->numeric_adr[id];
    EXPECT_EQ(std::vector<double>(data, data + m->numeric_size[id]), home) << numeric;
  }
  EXPECT_EQ(FindRobot("franka_droid"), RobotsDir() / "franka_droid" / "robot.yaml");
}

TEST(RobotSpecTest, TheHashFollowsTheFiles) {
  testing::TempDir tmp;
  const fs::path same = EditedFranka(tmp, "gravcomp: true", "gravcomp: true");
  const std::string before = LoadRobotDescription(same).hash;
  EXPECT_EQ(before, LoadRobotDescription(kFranka).hash);
  std::ofstream(same / "franka_droid.xml", std::ios::app) << "<!-- edited -->\n";
  EXPECT_NE(LoadRobotDescription(same).hash, before);
}

TEST(RobotSpecTest, BadDescriptionsAreOneLineNamingFileAndField) {
  testing::TempDir tmp;
  struct Case {
    std::string from, to, field, message;
  };
  const Case cases[] = {
      {"gravcomp: true", "gravcom: true", "gravcom", "did you mean 'gravcomp'"},
      {"tcp_site: gripper/grasp_site", "tcp_site: gripper/nope", "tcp_site",
       "site 'gripper/nope' is not in franka_droid.xml"},
      {"fr3_joint7]", "fr3_joint8]", "arm.joints[6]", "joint 'fr3_joint8'"},
      {"1.57079, 0.0]", "1.57079]", "arm.home", "6 values for 7 arm joints"},
      {"home: [0.00296, 0.00296]", "home: [.nan, 0.00296]", "gripper.home[0]", "finite"},
      {"finger_range: [0.0, 0.085]", "finger_range: [0.09, 0.085]", "gripper.finger_range",
       "0 <= closed < open"},
      {"root_body: fr3_link0", "root_body: fr3_link1", "root_body", "not a child of the base"},
      {"kind: mocap", "kind: wheels", "base.kind", "wheels"},
      {"closed_ctrl: 255", "closed_ctrl: 300", "gripper.closed_ctrl", "ctrlrange"},
      {"mjcf: franka_droid.xml", "mjcf: missing.xml", "mjcf", "file not found"},
      {"reference_body: fr3_link0", "reference_body: nope", "cameras[1].reference_body",
       "body 'nope'"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.to);
    const fs::path dir = EditedFranka(tmp, c.from, c.to);
    testing::ExpectError([&] { LoadRobotDescription(dir); },
                         {(dir / "robot.yaml").string(), c.field, c.message});
    const std::vector<std::string> lines = CheckRobotDescription(dir);
    ASSERT_FALSE(lines.empty());
    EXPECT_THAT(lines[0], HasSubstr(c.field));
  }
  // Two problems at once: CheckRobotDescription lists both, the loader throws the first.
  const fs::path two = EditedFranka(tmp, "tcp_site: gripper/grasp_site", "tcp_site: gripper/nope");
  std::string text = testing::Slurp(two / "robot.yaml");
  text.replace(text.find("closed_ctrl: 255"), 16, "closed_ctrl: 300");
  testing::WriteText(two / "robot.yaml", text);
  const std::vector<std::string> lines = CheckRobotDescription(two);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_THAT(lines[0], HasSubstr("tcp_site: site 'gripper/nope'"));
  EXPECT_THAT(lines[1], HasSubstr("gripper.closed_ctrl: 300"));
}

TEST(RobotSpecTest, UserRobotsAreFoundByNameOnMLSPACES_ROBOT_PATH) {
  testing::TempDir tmp;
  const fs::path mine = tmp.path() / "mine" / "my_franka";
  fs::create_directories(mine);
  fs::copy_file(kFranka / "franka_droid.xml", mine / "franka_droid.xml");
  std::string text = testing::Slurp(kFranka / "robot.yaml");
  text.replace(text.find("name: franka_droid"), 18, "name: my_franka");
  testing::WriteText(mine / "robot.yaml", text);
  const std::string path = "/nonexistent:" + (tmp.path() / "mine").string();
  ::setenv("MLSPACES_ROBOT_PATH", path.c_str(), 1);
  EXPECT_EQ(FindRobot("my_franka"), mine / "robot.yaml");
  EXPECT_EQ(LoadRobotSpec("my_franka").name, "my_franka");
  EXPECT_THAT(BundledRobots(), ::testing::IsSupersetOf({"franka_droid", "my_franka"}));
  EXPECT_EQ(FindRobot("franka_droid"), RobotsDir() / "franka_droid" / "robot.yaml");
  ::unsetenv("MLSPACES_ROBOT_PATH");
  testing::ExpectError([] { FindRobot("my_franka"); }, {"unknown robot 'my_franka'"});
}

TEST(RobotSpecTest, UnknownRobotNamesTheFieldAndTheBundledRobots) {
  testing::ExpectError([] { FindRobot("franka_drod"); },
                       {"robot_config.name", "unknown robot 'franka_drod'", "franka_droid",
                        "did you mean 'franka_droid'"});
  testing::ExpectError([] { FindRobot("./no/such/robot"); },
                       {"robot_config.name", "no robot description"});
}

}  // namespace
}  // namespace mlspaces::robots
