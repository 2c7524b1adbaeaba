// sim::DescribeModel and its JSON form (src/sim/describe.cc), what `mlspaces inspect` prints.
#include "mlspaces/sim/describe.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;

constexpr const char* kXml = R"(<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <camera name="overhead" pos="0 0 2"/>
    <body name="arm" pos="0 0 0.5">
      <joint name="shoulder" type="hinge" range="-1 1"/>
      <geom type="box" size="0.1 0.2 0.3" mass="2"/>
      <body name="hand" pos="0 0 0.4">
        <joint name="wrist" type="slide"/>
        <geom type="sphere" size="0.01"/>
      </body>
    </body>
  </worldbody>
  <actuator><position name="drive" joint="shoulder" ctrlrange="-0.5 0.5"/></actuator>
</mujoco>)";

TEST(DescribeModelTest, ListsBodiesJointsActuatorsAndCameras) {
  const MjcfComposer composer = MjcfComposer::FromString(kXml, fs::path("/tmp/describe.xml"));
  const ModelDescription d = DescribeModel(composer, "given.xml");
  EXPECT_EQ(d.file, "given.xml");
  EXPECT_EQ(d.ngeom, 2);
  ASSERT_EQ(d.bodies.size(), 3u);
  EXPECT_EQ(d.bodies[0].name, "world");
  EXPECT_FALSE(d.bodies[0].box.has_value());  // the world holds no geom here
  EXPECT_EQ(d.bodies[1].name, "arm");
  EXPECT_EQ(d.bodies[1].parent, "world");
  EXPECT_EQ(d.bodies[1].pose.pos, (Vec3{0, 0, 0.5}));
  EXPECT_EQ(d.bodies[1].pose.quat, (Quat{1, 0, 0, 0}));
  EXPECT_DOUBLE_EQ(d.bodies[1].mass, 2);
  EXPECT_EQ(d.bodies[1].ngeom, 1);
  ASSERT_TRUE(d.bodies[1].box.has_value());
  EXPECT_NEAR((*d.bodies[1].box)[0][2], 0.2, 1e-12);
  EXPECT_NEAR((*d.bodies[1].box)[1][1], 0.2, 1e-12);
  EXPECT_EQ(d.bodies[2].parent, "arm");
  EXPECT_NEAR(d.bodies[2].pose.pos[2], 0.9, 1e-15);
  ASSERT_EQ(d.joints.size(), 2u);
  EXPECT_EQ(d.joints[0].type, "hinge");
  EXPECT_EQ(d.joints[0].body, "arm");
  ASSERT_TRUE(d.joints[0].range.has_value());
  EXPECT_EQ(*d.joints[0].range, (std::array<double, 2>{-1, 1}));
  EXPECT_EQ(d.joints[1].type, "slide");
  EXPECT_FALSE(d.joints[1].range.has_value());
  ASSERT_EQ(d.actuators.size(), 1u);
  EXPECT_EQ(d.actuators[0].transmission, "joint");
  EXPECT_EQ(d.actuators[0].target, "shoulder");
  EXPECT_EQ(*d.actuators[0].ctrlrange, (std::array<double, 2>{-0.5, 0.5}));
  ASSERT_EQ(d.cameras.size(), 1u);
  EXPECT_EQ(d.cameras[0].body, "world");
  EXPECT_EQ(d.cameras[0].name, "overhead");
}

TEST(DescribeModelTest, JsonFormKeepsTheInspectLayout) {
  const MjcfComposer composer = MjcfComposer::FromString(kXml, fs::path("/tmp/describe.xml"));
  const Json j = ToJson(DescribeModel(composer, "given.xml"));
  std::vector<std::string> keys;
  for (auto it = j.begin(); it != j.end(); ++it) keys.push_back(it.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"file", "bodies", "joints", "actuators", "cameras",
                                            "warnings"}));
  const Json& arm = j["bodies"][1];
  EXPECT_EQ(arm["name"], "arm");
  EXPECT_EQ(arm["pos"], Json::parse("[0.0, 0.0, 0.5]"));
  EXPECT_EQ(arm["ngeom"], 1);
  EXPECT_TRUE(j["bodies"][0]["aabb"].is_null());
  EXPECT_NEAR(arm["aabb"]["max"][1].get<double>(), 0.2, 1e-12);
  EXPECT_TRUE(j["joints"][1]["range"].is_null());
  EXPECT_EQ(j["actuators"][0]["ctrlrange"], Json::parse("[-0.5, 0.5]"));
  EXPECT_EQ(j["cameras"][0]["fovy"], 45.0);
  EXPECT_TRUE(j["warnings"].is_array());
}

TEST(DescribeModelTest, WarningsAreDiagnosticsAndJsonStrings) {
  ModelDescription d;
  d.file = "given.xml";
  d.warnings.emplace_back("/tmp/describe.xml", "", "Warning: something odd", "",
                          Severity::kWarning);
  EXPECT_EQ(MujocoWarningLine(d.warnings[0]), "MuJoCo: Warning: something odd");
  EXPECT_EQ(ToJson(d)["warnings"], Json::parse(R"(["MuJoCo: Warning: something odd"])"));
}

}  // namespace
}  // namespace mlspaces::sim
