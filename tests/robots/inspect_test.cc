// `mlspaces inspect-robot` (robots/inspect.h, apps/mlspaces/robots_inspect.cc) on real MuJoCo:
// franka_droid passes; a broken copy (wrong finger_range, flipped TCP site, a missing joint)
// gives one line per problem and exit 1; --settle-time is honoured; --json parses; unknown
// names and bad flags are usage errors. Reachability grids are kept small (a few targets).
#include "mlspaces/robots/inspect.h"

#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "test_util.h"

namespace mlspaces::robots {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::StartsWith;

const fs::path kFranka = fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid";

// 2 x 3 x 2 targets in front of the robot.
InspectOptions SmallGrid() {
  InspectOptions o;
  o.grid_x = {0.4, 0.6};
  o.grid_y = {-0.2, 0.2};
  o.grid_z = {0.2, 0.4};
  o.grid_step = 0.2;
  return o;
}

// `text` with `from` replaced by `to` (once; `from` must be there).
std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// A copy of franka_droid with a wrong finger_range, the TCP site turned 180 deg about its x
// axis (+z into the palm) and arm.joints[6] naming a joint the MJCF does not have.
fs::path BrokenFranka(const testing::TempDir& tmp) {
  fs::path dir = tmp.path() / "broken_robot";
  std::string xml = testing::Slurp(kFranka / "franka_droid.xml");
  xml = Replace(xml, R"(<site name="gripper/grasp_site" pos="0 0 0.14")",
                R"(<site name="gripper/grasp_site" pos="0 0 0.14" quat="0 1 0 0")");
  testing::WriteText(dir / "franka_droid.xml", xml);
  std::string yaml = testing::Slurp(kFranka / "robot.yaml");
  yaml = Replace(yaml, "finger_range: [0.0, 0.085]", "finger_range: [0.0, 0.05]");
  yaml = Replace(yaml, "fr3_joint6, fr3_joint7]", "fr3_joint6, fr3_joint8]");
  testing::WriteText(dir / "robot.yaml", yaml);
  return dir;
}

TEST(InspectRobotTest, FrankaDroidHasNoProblems) {
  const RobotReport r = InspectRobot("franka_droid", SmallGrid());
  EXPECT_TRUE(r.problems.empty()) << ::testing::PrintToString(r.problems);
  ASSERT_TRUE(r.loaded);
  EXPECT_EQ(r.name, "franka_droid");
  EXPECT_EQ(r.file, fs::absolute(kFranka / "robot.yaml").lexically_normal());
  EXPECT_EQ(r.hash.size(), 16u);
  // fr3_link0 .. fr3_link7 and the gripper base; one arm hinge on each link 1..7.
  ASSERT_EQ(r.chain.size(), 9u);
  EXPECT_EQ(r.chain.front().name, "fr3_link0");
  EXPECT_EQ(r.chain.back().name, "gripper/base");
  for (size_t k = 1; k <= 7; ++k) {
    ASSERT_EQ(r.chain[k].joints.size(), 1u) << r.chain[k].name;
    EXPECT_EQ(r.chain[k].joints[0].name, "fr3_joint" + std::to_string(k));
    EXPECT_EQ(r.chain[k].joints[0].type, "hinge");
    EXPECT_TRUE(r.chain[k].joints[0].arm);
    EXPECT_TRUE(r.chain[k].joints[0].range.has_value());
  }
  EXPECT_EQ(r.arm_dof, 7);
  EXPECT_EQ(r.gripper_drivers, 2);
  EXPECT_EQ(r.gripper_dof, 4);  // two drivers, two followers
  ASSERT_EQ(r.arm_actuators.size(), 7u);
  EXPECT_EQ(r.arm_actuators[0].target, "joint fr3_joint1");
  EXPECT_DOUBLE_EQ(r.arm_actuators[0].gain, 4500);
  ASSERT_TRUE(r.gripper_actuator.has_value());
  EXPECT_EQ(r.gripper_actuator->ctrl_range, (std::array<double, 2>{0, 255}));
  // Home: within limits, TCP in front of the base pointing down.
  EXPECT_TRUE(r.home.skipped.empty());
  EXPECT_TRUE(r.home.within_limits);
  EXPECT_GT(r.home.tcp.pos[0], 0.2);
  EXPECT_GT(r.home.tcp.pos[2], 0.3);
  // TCP convention: +z along palm-to-pads, pads along y, pad midpoint near the TCP.
  EXPECT_TRUE(r.tcp.ok);
  EXPECT_LT(r.tcp.approach_angle_deg, 1.0);
  EXPECT_LT(r.tcp.finger_axis_angle_deg, 1.0);
  EXPECT_LT(std::abs(r.tcp.pad_midpoint_in_tcp[2]), 0.01);
  // Gripper travel in simulation within 2 mm of robot.yaml's [0, 0.085] (the primitive 2F-85
  // opens to 85 mm, README.md).
  EXPECT_TRUE(r.gripper.ok);
  EXPECT_NEAR(r.gripper.closed_gap, 0.0, 0.002);
  EXPECT_NEAR(r.gripper.open_gap, 0.085, 0.002);
  EXPECT_DOUBLE_EQ(r.gripper.settle_time, 1.0);
  // Reachability: every target of the small grid is within the FR3's reach.
  EXPECT_TRUE(r.reachability.skipped.empty());
  EXPECT_EQ(r.reachability.targets, 12);
  EXPECT_EQ(r.reachability.reached, 12);
  ASSERT_TRUE(r.reachability.envelope.has_value());
  EXPECT_EQ((*r.reachability.envelope)[0], (Vec3{0.4, -0.2, 0.2}));
  EXPECT_EQ((*r.reachability.envelope)[1], (Vec3{0.6, 0.2, 0.4}));
  // Deterministic: the same report again, to the bit.
  EXPECT_EQ(ToJson(InspectRobot(kFranka.string(), SmallGrid())), ToJson(r));
  EXPECT_THAT(FormatRobotReport(r), HasSubstr("problems: none\n"));
}

TEST(InspectRobotTest, OutOfReachTargetsAreCounted) {
  InspectOptions o = SmallGrid();
  o.grid_x = {0.6, 1.4};  // 1.0 and 1.4 m are past the FR3's ~0.86 m reach
  o.grid_y = {0, 0};
  o.grid_z = {0.3, 0.3};
  o.grid_step = 0.4;
  const RobotReport r = InspectRobot("franka_droid", o);
  EXPECT_TRUE(r.problems.empty()) << ::testing::PrintToString(r.problems);
  EXPECT_EQ(r.reachability.targets, 3);
  EXPECT_EQ(r.reachability.reached, 1);
  ASSERT_TRUE(r.reachability.envelope.has_value());
  EXPECT_EQ((*r.reachability.envelope)[1][0], 0.6);
}

TEST(InspectRobotTest, SettleTimeIsHonoured) {
  InspectOptions o;
  o.reachability = false;
  o.settle_time = 0.02;  // 10 steps: the fingers have not closed yet
  const RobotReport r = InspectRobot("franka_droid", o);
  EXPECT_DOUBLE_EQ(r.gripper.settle_time, 0.02);
  EXPECT_GT(r.gripper.closed_gap, 0.01);
  EXPECT_FALSE(r.gripper.ok);
  EXPECT_THAT(r.problems,
              Contains(AllOf(HasSubstr("robot.yaml: gripper.finger_range[0]: the closed gap"),
                             HasSubstr("0.02 s"))));
  EXPECT_EQ(r.reachability.skipped, "not asked for");
}

TEST(InspectRobotTest, BrokenCopyGivesOneLinePerProblem) {
  testing::TempDir tmp;
  const fs::path dir = BrokenFranka(tmp);
  const std::string file = (dir / "robot.yaml").string();
  InspectOptions o = SmallGrid();
  const RobotReport r = InspectRobot(dir.string(), o);
  ASSERT_TRUE(r.loaded);
  for (const std::string& line : r.problems) {
    EXPECT_THAT(line, StartsWith(file + ": ")) << line;
    EXPECT_EQ(line.find('\n'), std::string::npos) << line;
  }
  EXPECT_THAT(r.problems, Contains(AllOf(StartsWith(file + ": arm.joints[6]: "),
                                         HasSubstr("'fr3_joint8' is not in franka_droid.xml"))));
  // The joint the arm list lost is on the chain, listed nowhere.
  EXPECT_THAT(r.problems, Contains(file + ": arm.joints: joint 'fr3_joint7' on the chain from "
                                          "root_body to tcp_site is not listed (nothing would "
                                          "move it)"));
  EXPECT_THAT(r.problems, Contains(AllOf(StartsWith(file + ": tcp_site: +z is 180.0 deg from the "
                                                           "palm-to-fingertips direction"))));
  EXPECT_THAT(r.problems,
              Contains(AllOf(StartsWith(file + ": gripper.finger_range[1]: the open gap measured "
                                               "in simulation is 0.0850 m"),
                             HasSubstr("robot.yaml says 0.0500 m: more than 2 mm off"))));
  EXPECT_FALSE(r.tcp.ok);
  EXPECT_NEAR(r.tcp.approach_angle_deg, 180.0, 0.1);
  EXPECT_LT(r.tcp.finger_axis_angle_deg, 1.0);  // y flipped too: still along +-y
  EXPECT_EQ(r.arm_dof, 6);
  EXPECT_EQ(r.reachability.skipped,
            "needs tcp_site and every arm joint with its servo in the model");

  // The CLI prints the same lines and exits 1.
  const testing::CliResult cli = testing::RunCli({"inspect-robot", dir.string(), "--no-ik"});
  EXPECT_EQ(cli.exit_code, 1) << cli.err;
  EXPECT_EQ(cli.err, "");
  for (const std::string& line : r.problems) EXPECT_THAT(cli.out, HasSubstr("\n" + line + "\n"));
  EXPECT_THAT(cli.out, HasSubstr("TCP convention: PROBLEM"));
  EXPECT_THAT(cli.out, HasSubstr("reachability: not measured (not asked for)"));
}

TEST(InspectRobotTest, UnreadableDescriptionPrintsOnlyItsProblems) {
  testing::TempDir tmp;
  const fs::path dir = tmp.path() / "bad";
  fs::create_directories(dir);
  fs::copy_file(kFranka / "franka_droid.xml", dir / "franka_droid.xml");
  testing::WriteText(dir / "robot.yaml", Replace(testing::Slurp(kFranka / "robot.yaml"),
                                                 "gravcomp: true", "gravcomp: true\nwheels: 4"));
  const RobotReport r = InspectRobot((dir / "robot.yaml").string());
  EXPECT_FALSE(r.loaded);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_THAT(r.problems[0], AllOf(HasSubstr("robot.yaml"), HasSubstr("wheels")));
  const testing::CliResult cli = testing::RunCli({"inspect-robot", dir.string()});
  EXPECT_EQ(cli.exit_code, 1);
  EXPECT_EQ(cli.out, r.problems[0] + "\n");
}

TEST(InspectRobotTest, JsonParses) {
  const testing::CliResult cli =
      testing::RunCli({"inspect-robot", "franka_droid", "--json", "--grid-x", "0.5", "0.5",
                       "--grid-y", "-0.1", "0.1", "--grid-z", "0.3", "0.3", "--settle-time", "1"});
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  const Json j = ParseJson(cli.out, "stdout");
  EXPECT_EQ(j["name"], "franka_droid");
  EXPECT_EQ(j["problems"], Json::array());
  EXPECT_EQ(j["loaded"], true);
  EXPECT_EQ(j["dof"]["arm"], 7);
  EXPECT_EQ(j["chain"].size(), 9u);
  EXPECT_EQ(j["tcp"]["ok"], true);
  EXPECT_EQ(j["gripper_travel"]["ok"], true);
  EXPECT_EQ(j["reachability"]["targets"], 3);
  EXPECT_EQ(j["reachability"]["reached"], 3);
  EXPECT_EQ(j["reachability"]["grid_y"], Json::array({-0.1, 0.1}));
}

TEST(InspectRobotTest, UnknownRobotIsOneUsageLine) {
  const testing::CliResult cli = testing::RunCli({"inspect-robot", "franka_drod"});
  EXPECT_EQ(cli.exit_code, 2);
  EXPECT_EQ(cli.out, "");
  EXPECT_THAT(cli.err, AllOf(StartsWith("mlspaces: error: robot: unknown robot 'franka_drod'"),
                             HasSubstr("did you mean 'franka_droid'")));
  EXPECT_EQ(std::count(cli.err.begin(), cli.err.end(), '\n'), 1) << cli.err;
  testing::ExpectError([] { InspectRobot("franka_drod"); }, {"robot: unknown robot"});
  const testing::CliResult no_yaml = testing::RunCli({"inspect-robot", "/nonexistent/robot"});
  EXPECT_EQ(no_yaml.exit_code, 2);
  EXPECT_THAT(no_yaml.err, HasSubstr("no robot description (robot.yaml) at /nonexistent/robot"));
}

TEST(InspectRobotTest, BadOptionsAreUsageErrors) {
  EXPECT_EQ(testing::RunCli({"inspect-robot", "franka_droid", "--settle-time", "0"}).exit_code, 2);
  // NaN and infinity are refused at the flag, which the line names (CLI11's Range let NaN
  // through to the check of settle_time; inf printed a 300-digit range).
  for (const auto& [flag, value, says] : std::vector<std::array<std::string, 3>>{
           {"--settle-time", "nan", "--settle-time: expected a number in [0.001, 60], got 'nan'"},
           {"--finger-tolerance", "2", "--finger-tolerance: expected a number in [0, 1], got '2'"},
           {"--tcp-tolerance", "inf", "--tcp-tolerance: expected a number in [0, 180], got 'inf'"},
           {"--grid-step", "inf", "--grid-step: expected a number > 0, got 'inf'"}}) {
    const testing::CliResult r = testing::RunCli({"inspect-robot", "franka_droid", flag, value});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err, "mlspaces: error: " + says + " (see --help)\n");
  }
  EXPECT_THAT(testing::RunCli({"inspect-robot", "--help"}).out,
              HasSubstr("--settle-time S in [0.001, 60]=1"));
  EXPECT_EQ(testing::RunCli({"inspect-robot", "franka_droid", "--grid-x", "0.5"}).exit_code, 2);
  const testing::CliResult reversed =
      testing::RunCli({"inspect-robot", "franka_droid", "--grid-x", "0.8", "0.3"});
  EXPECT_EQ(reversed.exit_code, 2);
  EXPECT_THAT(reversed.err, HasSubstr("grid_x: must be [min, max]"));
  InspectOptions o;
  o.grid_step = 0;
  EXPECT_THROW(InspectRobot("franka_droid", o), UsageError);
}

}  // namespace
}  // namespace mlspaces::robots
