// Joints of articulated assets and candidates on their handles (src/graspgen/joints.cc), on
// the example cabinet (examples/objects/cabinet_drawer_door) and assets the test writes.
#include "mlspaces/graspgen/joints.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "test_util.h"

namespace mlspaces::graspgen {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

const std::filesystem::path kCabinet = std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "objects" /
                                       "cabinet_drawer_door" / "cabinet_drawer_door.xml";

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

Vec3 At(const Mat4& t, const Vec3& p) {
  return {t(0, 0) * p[0] + t(0, 1) * p[1] + t(0, 2) * p[2] + t(0, 3),
          t(1, 0) * p[0] + t(1, 1) * p[1] + t(1, 2) * p[2] + t(1, 3),
          t(2, 0) * p[0] + t(2, 1) * p[1] + t(2, 2) * p[2] + t(2, 3)};
}

void ExpectVec(const Vec3& a, const Vec3& b, double tol = 1e-12) {
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[k], b[k], tol) << "component " << k;
}

// Distance from p to the mesh's nearest vertex.
double NearestVertex(const TriMesh& m, const Vec3& p) {
  double best = 1e300;
  for (const Vec3& v : m.vertices) {
    best = std::min(best, std::hypot(v[0] - p[0], v[1] - p[1], v[2] - p[2]));
  }
  return best;
}

// The corners of box geom `geom` in the frame of body `body`, from MuJoCo's own kinematics.
std::vector<Vec3> BoxCornersInBody(const std::filesystem::path& asset, const char* geom,
                                   const char* body) {
  const sim::ModelPtr m = sim::ComposeAndCompile(asset);
  const sim::DataPtr d(mj_makeData(m.get()));
  mj_kinematics(m.get(), d.get());
  auto pose = [](const mjtNum* pos, const mjtNum* mat) {
    Rot3 r;
    std::copy_n(mat, 9, r.begin());
    return ToMat4(Vec3{pos[0], pos[1], pos[2]}, r);
  };
  const int g = mj_name2id(m.get(), mjOBJ_GEOM, geom), b = mj_name2id(m.get(), mjOBJ_BODY, body);
  EXPECT_GE(g, 0);
  EXPECT_GE(b, 0);
  const Mat4 t = InverseRigid(pose(d->xpos + 3 * b, d->xmat + 9 * b)) *
                 pose(d->geom_xpos + 3 * g, d->geom_xmat + 9 * g);
  const mjtNum* s = m->geom_size + 3 * g;
  std::vector<Vec3> out;
  out.reserve(8);
  for (int i = 0; i < 8; ++i) {
    out.push_back(
        At(t, {(i & 1 ? 1 : -1) * s[0], (i & 2 ? 1 : -1) * s[1], (i & 4 ? 1 : -1) * s[2]}));
  }
  return out;
}

TEST(GraspgenJointsTest, CabinetHasADrawerSlideAndADoorHinge) {
  const std::vector<JointTarget> t = FindJointTargets(kCabinet);
  ASSERT_EQ(t.size(), 2u);
  const JointTarget &drawer = t[0], &door = t[1];
  EXPECT_EQ(drawer.joint, "drawer_slide");
  EXPECT_EQ(drawer.body, "drawer");
  EXPECT_FALSE(drawer.hinge);
  ExpectVec(drawer.axis, {-1, 0, 0});  // out of the front, toward -x
  EXPECT_TRUE(drawer.limited);
  EXPECT_DOUBLE_EQ(drawer.range[0], 0);
  EXPECT_DOUBLE_EQ(drawer.range[1], 0.25);
  EXPECT_DOUBLE_EQ(drawer.travel, 0.25);
  EXPECT_THAT(drawer.handle_geoms, ElementsAre("drawer_handle_bar", "drawer_handle_post_left",
                                               "drawer_handle_post_right"));
  EXPECT_EQ(door.joint, "door_hinge");
  EXPECT_EQ(door.body, "door");
  EXPECT_TRUE(door.hinge);
  ExpectVec(door.axis, {0, 0, 1});
  ExpectVec(door.anchor, {0, -0.248, 0});  // the hinge edge, not the body origin (bug 21)
  EXPECT_TRUE(door.limited);
  EXPECT_DOUBLE_EQ(door.range[0], 0);
  EXPECT_NEAR(door.range[1], std::numbers::pi / 2, 1e-12);  // "0 90" in degrees, compiled
  EXPECT_NEAR(door.travel, std::numbers::pi / 2, 1e-12);
  EXPECT_THAT(door.handle_geoms,
              ElementsAre("door_handle_bar", "door_handle_post_top", "door_handle_post_bottom"));
  for (const JointTarget* j : {&drawer, &door}) {
    EXPECT_EQ(j->handle.faces.size(), 3u * 12);   // three boxes
    EXPECT_EQ(j->object.faces.size(), 18u * 12);  // every box of the cabinet
  }
}

// Handle and object meshes are in the joint body's frame at qpos0: the box corners MuJoCo's
// kinematics gives, expressed in that body's frame, are mesh vertices.
TEST(GraspgenJointsTest, MeshesAreInTheJointBodyFrame) {
  const std::vector<JointTarget> t = FindJointTargets(kCabinet);
  ASSERT_EQ(t.size(), 2u);
  for (const Vec3& c : BoxCornersInBody(kCabinet, "drawer_handle_bar", "drawer")) {
    EXPECT_LT(NearestVertex(t[0].handle, c), 1e-9);
  }
  // The drawer's bar: 0.064 m in front of the drawer body origin, 12 cm along y.
  EXPECT_LT(NearestVertex(t[0].handle, {-0.074, 0.06, 0.01}), 1e-9);
  for (const Vec3& c : BoxCornersInBody(kCabinet, "door_handle_bar", "door")) {
    EXPECT_LT(NearestVertex(t[1].handle, c), 1e-9);
  }
  for (const Vec3& c : BoxCornersInBody(kCabinet, "carcass_top", "door")) {
    EXPECT_LT(NearestVertex(t[1].object, c), 1e-9);
    EXPECT_GT(NearestVertex(t[1].handle, c), 0.1);
  }
  for (const Vec3& c : BoxCornersInBody(kCabinet, "door_panel", "drawer")) {
    EXPECT_LT(NearestVertex(t[0].object, c), 1e-9);
  }
}

TEST(GraspgenJointsTest, UnlimitedJointsEmptyHandlesAndSkippedJoints) {
  mlspaces::testing::TempDir dir;
  const auto path = dir.path() / "box_with_parts.xml";
  mlspaces::testing::WriteText(path, R"(<mujoco model="box_with_parts">
  <compiler angle="radian"/>
  <worldbody>
    <body name="base" pos="1 2 0.5" euler="0 0 0.7">
      <freejoint name="base_free"/>
      <geom name="base_box" type="box" size="0.1 0.1 0.1"/>
      <body name="lid" pos="0 0 0.1">
        <joint name="lid_hinge" axis="1 0 0" pos="0 -0.1 0"/>
        <geom name="lid_plate" type="box" pos="0 0 0.005" size="0.1 0.1 0.005"/>
      </body>
      <body name="tray" pos="0 0 -0.05">
        <joint name="tray_slide" type="slide" axis="0 1 0"/>
        <geom name="tray_box" type="box" size="0.05 0.1 0.01"/>
      </body>
      <body name="boom" pos="0.2 0 0" euler="0 0 1.5708">
        <joint name="boom_slide" type="slide" axis="1 0 0"/>
        <geom name="boom_rod" type="capsule" fromto="0 0 0 1 0 0" size="0.01"/>
      </body>
      <body name="knob" pos="0 0.2 0">
        <joint name="knob_ball" type="ball"/>
        <geom name="knob_sphere" type="sphere" size="0.02"/>
      </body>
      <body name="ghost" pos="0 -0.2 0">
        <joint name="ghost_hinge" type="hinge" axis="0 0 1" range="-1.5 0.2"/>
        <geom name="ghost_visual" type="sphere" size="0.02" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
)");
  const std::vector<JointTarget> t = FindJointTargets(path);
  ASSERT_EQ(t.size(), 4u);  // free and ball skipped
  EXPECT_EQ(t[0].joint, "lid_hinge");
  EXPECT_TRUE(t[0].hinge);  // no type attribute: a hinge, as in MuJoCo
  EXPECT_FALSE(t[0].limited);
  EXPECT_DOUBLE_EQ(t[0].travel, std::numbers::pi / 2);
  ExpectVec(t[0].anchor, {0, -0.1, 0});
  EXPECT_THAT(t[0].handle_geoms, ElementsAre("lid_plate"));  // no child body: its own geoms
  EXPECT_EQ(t[1].joint, "tray_slide");
  EXPECT_FALSE(t[1].hinge);
  EXPECT_NEAR(t[1].travel, 0.2, 1e-12);  // the tray's extent along y
  EXPECT_EQ(t[2].joint, "boom_slide");
  EXPECT_DOUBLE_EQ(t[2].travel, 0.4);  // 1.02 m long: capped
  EXPECT_EQ(t[3].joint, "ghost_hinge");
  EXPECT_TRUE(t[3].limited);
  EXPECT_DOUBLE_EQ(t[3].travel, -1.5);  // the range end farther from qpos0
  EXPECT_TRUE(t[3].handle_geoms.empty());
  EXPECT_TRUE(t[3].handle.faces.empty());
  EXPECT_EQ(t[3].object.faces.size(), t[0].object.faces.size());  // the whole object
  EXPECT_THAT(ErrorOf([&] { GenerateJointCandidates(t[3], FrankaDroidGripperProxy(), {}, 1); }),
              HasSubstr("joint ghost_hinge has no handle geometry"));
}

TEST(GraspgenJointsTest, NoHingeOrSlideJointIsAnErrorNamingTheFile) {
  mlspaces::testing::TempDir dir;
  const auto path = dir.path() / "ball.xml";
  mlspaces::testing::WriteText(path, R"(<mujoco model="ball">
  <worldbody>
    <body name="ball"><freejoint/><geom type="sphere" size="0.03"/>
      <body name="bob" pos="0 0 -0.1"><joint type="ball"/><geom type="sphere" size="0.01"/></body>
    </body>
  </worldbody>
</mujoco>
)");
  EXPECT_EQ(ErrorOf([&] { FindJointTargets(path); }),
            path.string() + ": no hinge or slide joint in body ball or below");
  EXPECT_THAT(ErrorOf([&] { FindJointTargets(dir.path() / "missing.xml"); }),
              HasSubstr("missing.xml"));
}

std::string Bytes(const CandidateSet& s) {
  std::string out;
  for (const GraspCandidate& c : s.candidates) {
    out.append(reinterpret_cast<const char*>(c.tcp.m.data()), sizeof(double) * 16);
    out.append(reinterpret_cast<const char*>(&c.quality), sizeof(double));
  }
  return out;
}

TEST(GraspgenJointsTest, CabinetCandidatesClearTheWholeObject) {
  const std::vector<JointTarget> targets = FindJointTargets(kCabinet);
  const GripperProxy g = FrankaDroidGripperProxy();
  CandidateParams p;
  p.threads = 1;
  for (const JointTarget& t : targets) {
    SCOPED_TRACE(t.joint);
    const CandidateSet s = GenerateJointCandidates(t, g, p, 7);
    ASSERT_FALSE(s.candidates.empty());
    EXPECT_EQ(s.stats.kept, s.candidates.size());
    Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (const Vec3& v : t.handle.vertices) {
      for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], v[k]), hi[k] = std::max(hi[k], v[k]);
    }
    const MeshBvh object(t.object);
    for (const GraspCandidate& c : s.candidates) {
      ASSERT_FALSE(HandCollides(object, g, c.tcp));
      EXPECT_GE(c.quality, p.min_quality);
      // TCP within 5.5 cm of the handle (standoffs put it 5.4 cm inside to 1.9 cm outside).
      for (int k = 0; k < 3; ++k) {
        EXPECT_GT(c.tcp(k, 3), lo[k] - 0.055);
        EXPECT_LT(c.tcp(k, 3), hi[k] + 0.055);
      }
      // Never from behind the front (+x in both joint bodies: into the cabinet).
      EXPECT_GT(c.tcp(0, 2), -0.5);
    }
    // Without the whole object, the same generator keeps candidates whose hand hits the front.
    const CandidateSet handle_only = GenerateCandidates(MeshBvh(t.handle), g, p, 7);
    EXPECT_GT(handle_only.candidates.size(), s.candidates.size());
    EXPECT_LE(s.candidates.size(), s.stats.collision_free);
    EXPECT_EQ(handle_only.stats.points, s.stats.points);
    EXPECT_EQ(handle_only.stats.visible, s.stats.visible);
    // Deterministic whatever the thread count; another seed samples other points.
    CandidateParams p2 = p;
    p2.threads = 2;
    EXPECT_EQ(Bytes(GenerateJointCandidates(t, g, p2, 7)), Bytes(s));
    EXPECT_NE(Bytes(GenerateJointCandidates(t, g, p, 8)), Bytes(s));
  }
}

}  // namespace
}  // namespace mlspaces::graspgen
