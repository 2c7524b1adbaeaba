// Runs `mlspaces inspect` on the tutorial scene and on broken MJCF.
#include <algorithm>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kScene =
    (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "scene.xml").string();

TEST(InspectCli, TextListsTheAttachedBlockAtItsFramePose) {
  auto r = RunCli({"inspect", kScene});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("2 bodies, 1 joints, 2 geoms, 0 actuators, 0 cameras"));
  EXPECT_THAT(r.out, HasSubstr("red_block                pos [0.4, 0, 0.025] quat [1, 0, 0, 0] "
                               "mass 0.125 box [0.375, -0.025, 0]..[0.425, 0.025, 0.05]"));
  EXPECT_THAT(r.out, HasSubstr("(unnamed)                free   body red_block"));
}

TEST(InspectCli, JsonIsMachineReadable) {
  auto r = RunCli({"inspect", kScene, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out);
  const nlohmann::json* block = nullptr;
  for (const auto& b : j["bodies"]) {
    if (b["name"] == "red_block") block = &b;
  }
  ASSERT_NE(block, nullptr) << r.out;
  EXPECT_DOUBLE_EQ((*block)["mass"].get<double>(), 0.125);
  EXPECT_NEAR((*block)["pos"][0].get<double>(), 0.4, 1e-12);
  EXPECT_NEAR((*block)["pos"][2].get<double>(), 0.025, 1e-12);
}

TEST(InspectCli, EmitMjcfIsPlainMjcfThatMujocoLoads) {
  auto r = RunCli({"inspect", kScene, "--emit-mjcf"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("<mujoco"));
  EXPECT_THAT(r.out, Not(HasSubstr("<frame")));
  EXPECT_THAT(r.out, Not(HasSubstr("<attach")));
  EXPECT_THAT(r.out, Not(HasSubstr("<model")));
  EXPECT_THAT(r.out, HasSubstr("name=\"red_block\" pos=\"0.4 0 0.025\""));
}

TEST(InspectCli, BadMjcfIsOneLineWithFileLineAndElement) {
  TempDir tmp;
  const fs::path bad = tmp.path() / "bad.xml";
  WriteText(bad,
            "<mujoco>\n  <worldbody>\n    <geom type=\"box\" size=\"0.1 oops 0.1\"/>\n"
            "  </worldbody>\n</mujoco>\n");
  auto r = RunCli({"inspect", bad.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(bad.string() + ": line 3, element <geom>"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;

  // An error in an included file names that file and its line.
  WriteText(tmp.path() / "part.xml",
            "<mujoco>\n  <worldbody>\n\n    <gizmo/>\n  </worldbody>\n</mujoco>\n");
  WriteText(tmp.path() / "main.xml", "<mujoco>\n  <include file=\"part.xml\"/>\n</mujoco>\n");
  r = RunCli({"inspect", (tmp.path() / "main.xml").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr((tmp.path() / "part.xml").string() + ": line 4, element <gizmo>"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;

  r = RunCli({"inspect", (tmp.path() / "missing.xml").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("missing.xml"));
}

}  // namespace
}  // namespace mlspaces
