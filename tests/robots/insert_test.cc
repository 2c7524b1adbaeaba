// Putting robots into scenes (robots/insert.h): the three base kinds, the pedestal, gravcomp.
#include "mlspaces/robots/insert.h"

#include <cmath>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/robots/robot_view.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "test_util.h"

namespace mlspaces::robots {
namespace {

namespace fs = std::filesystem;
const fs::path kFranka = fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid";

// franka_droid's folder copied with its base section replaced by `base` (YAML lines).
RobotSpec FrankaWithBase(const testing::TempDir& tmp, const std::string& base) {
  const fs::path dir = tmp.path() / "robot";
  fs::create_directories(dir);
  fs::copy_file(kFranka / "franka_droid.xml", dir / "franka_droid.xml",
                fs::copy_options::overwrite_existing);
  std::string text = testing::Slurp(kFranka / "robot.yaml");
  const std::string old =
      "base:\n  kind: mocap\n  body: base            # the MJCF's own top mocap body\n";
  const size_t at = text.find(old);
  EXPECT_NE(at, std::string::npos);
  text.replace(at, old.size(), base);
  testing::WriteText(dir / "robot.yaml", text);
  return MakeRobotSpec(LoadRobotDescription(dir));
}

struct Compiled {
  sim::ModelPtr model;
  sim::DataPtr data;
};

Compiled InsertAndCompile(const testing::TempDir& tmp, const RobotSpec& spec) {
  testing::WriteText(tmp.path() / "scene.xml",
                     "<mujoco><worldbody><geom name=\"floor\" type=\"plane\" size=\"2 2 0.1\"/>"
                     "</worldbody></mujoco>\n");
  sim::Scene scene = sim::Scene::Load(tmp.path() / "scene.xml");
  InsertRobot(scene, spec);
  Compiled c{scene.Compile(), nullptr};
  ApplyRobotSettings(c.model.get(), spec);
  c.data = sim::MakeData(c.model.get());
  return c;
}

double Yaw(const Quat& q) {
  return std::atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
}

TEST(InsertTest, HolonomicBaseIsPlanarJointsHeldByServos) {
  testing::TempDir tmp;
  const RobotSpec spec = FrankaWithBase(tmp, "base:\n  kind: holonomic\n");
  EXPECT_FALSE(spec.base_in_model);
  Compiled c = InsertAndCompile(tmp, spec);
  const mjModel* m = c.model.get();
  mjData* d = c.data.get();
  for (const char* name : {"robot_0/base_x", "robot_0/base_y", "robot_0/base_yaw"}) {
    EXPECT_GE(mj_name2id(m, mjOBJ_JOINT, name), 0) << name;
    EXPECT_GE(mj_name2id(m, mjOBJ_ACTUATOR, name), 0) << name;
  }
  const RobotBase base(m, spec);
  const RobotView view(m, spec);
  const Pose target{{0.3, -0.2, 0}, {std::cos(0.25), 0, 0, std::sin(0.25)}};
  base.Set(m, d, target);
  for (size_t i = 0; i < spec.home_arm.size(); ++i) {
    d->qpos[view.arm_qpos_adr()[i]] = spec.home_arm[i];
  }
  view.SetArmTargets(d, spec.home_arm);
  mj_forward(m, d);
  const Pose got = base.Get(m, d);
  EXPECT_NEAR(got.pos[0], 0.3, 1e-12);
  EXPECT_NEAR(got.pos[1], -0.2, 1e-12);
  EXPECT_NEAR(Yaw(got.quat), 0.5, 1e-12);
  const Mat4 body = view.BasePose(d);
  EXPECT_NEAR(body(0, 3), 0.3, 1e-12);
  EXPECT_NEAR(body(1, 3), -0.2, 1e-12);
  // The servos hold the base while the arm moves.
  view.Step(d, 500);
  const Pose held = base.Get(m, d);
  EXPECT_NEAR(held.pos[0], 0.3, 1e-3);
  EXPECT_NEAR(held.pos[1], -0.2, 1e-3);
  EXPECT_NEAR(Yaw(held.quat), 0.5, 1e-3);
  testing::ExpectError(
      [&] {
        base.Set(m, d, Pose{{0, 0, 0.2}, {1, 0, 0, 0}});
      },
      {"robot.yaml: base.kind: the holonomic base robot_0/base", "x, y and yaw only"});
}

TEST(InsertTest, FixedBaseRefusesToMoveAndMocapWithoutModelBaseIsCreated) {
  testing::TempDir tmp;
  const RobotSpec fixed = FrankaWithBase(tmp, "base:\n  kind: fixed\n");
  Compiled c = InsertAndCompile(tmp, fixed);
  const RobotBase base(c.model.get(), fixed);
  EXPECT_EQ(c.model->body_mocapid[base.body()], -1);
  base.Set(c.model.get(), c.data.get(), Pose{});  // where it is: fine
  testing::ExpectError(
      [&] {
        base.Set(c.model.get(), c.data.get(), Pose{{0.1, 0, 0}, {1, 0, 0, 0}});
      },
      {"robot.yaml: base.kind: the robot's base robot_0/base is fixed"});

  testing::TempDir tmp2;
  RobotSpec mocap = FrankaWithBase(tmp2, "base:\n  kind: mocap\n");
  mocap.pedestal_size = std::array<double, 3>{0.4, 0.4, 0.3};
  Compiled c2 = InsertAndCompile(tmp2, mocap);
  const mjModel* m = c2.model.get();
  const RobotBase mb(m, mocap);
  EXPECT_GE(m->body_mocapid[mb.body()], 0);
  EXPECT_GE(mj_name2id(m, mjOBJ_GEOM, "robot_0/pedestal"), 0);
  mb.Set(m, c2.data.get(), Pose{{1, 2, 0}, {1, 0, 0, 0}});
  mj_forward(m, c2.data.get());
  const int root = mj_name2id(m, mjOBJ_BODY, "robot_0/fr3_link0");
  EXPECT_NEAR(c2.data->xpos[3 * root + 2], 0.3, 1e-12);  // on the pedestal's top
  EXPECT_NEAR(c2.data->xpos[3 * root], 1, 1e-12);
  EXPECT_EQ(m->body_gravcomp[root], 1);
}

}  // namespace
}  // namespace mlspaces::robots
