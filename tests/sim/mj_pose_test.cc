// MuJoCo's pose arrays <-> Pose / Mat4 (src/sim/mj_pose.cc) and InSubtree.
#include "mlspaces/sim/mj_pose.h"

#include <gtest/gtest.h>

#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {
namespace {

constexpr const char* kXml = R"(<mujoco>
  <worldbody>
    <body name="a" pos="0.1 0.2 0.3" quat="0.9 0.1 -0.3 0.2">
      <geom name="ga" type="box" size="0.1 0.1 0.1" pos="0.05 0 0" euler="0 30 0"/>
      <body name="b" pos="0 0.4 0" euler="10 20 30">
        <site name="s" pos="0.01 0.02 0.03" euler="45 0 0"/>
        <geom type="sphere" size="0.02"/>
      </body>
    </body>
    <body name="c" pos="1 0 0"><freejoint/><geom type="sphere" size="0.05"/></body>
  </worldbody>
</mujoco>)";

void ExpectNear(const Mat4& a, const Mat4& b, double tol) {
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(a.m[i], b.m[i], tol) << i;
}

TEST(MjPoseTest, BodySiteAndGeomPosesMatchMujoco) {
  ModelPtr m = LoadModelFromMemory(kXml);
  DataPtr d = MakeData(m.get());
  mj_kinematics(m.get(), d.get());
  const int b = mj_name2id(m.get(), mjOBJ_BODY, "b");
  const Pose pose = BodyPose(d.get(), b);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(pose.pos[i], d->xpos[3 * b + i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(pose.quat[i], d->xquat[4 * b + i]);
  // The quaternion form and MuJoCo's xmat agree.
  ExpectNear(ToMat4(pose), FrameToMat4(d->xpos + 3 * b, d->xmat + 9 * b), 1e-12);

  const int s = mj_name2id(m.get(), mjOBJ_SITE, "s");
  const Mat4 site = SiteMat4(d.get(), s);
  for (int r = 0; r < 3; ++r) {
    EXPECT_EQ(site(r, 3), d->site_xpos[3 * s + r]);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(site(r, c), d->site_xmat[9 * s + 3 * r + c]);
  }
  const int g = mj_name2id(m.get(), mjOBJ_GEOM, "ga");
  const Mat4 geom = GeomMat4(d.get(), g);
  EXPECT_EQ(geom(0, 3), d->geom_xpos[3 * g]);
  EXPECT_EQ(geom(2, 1), d->geom_xmat[9 * g + 7]);
  EXPECT_EQ(geom(3, 3), 1.0);
}

TEST(MjPoseTest, FreeJointRoundTripIsExact) {
  ModelPtr m = LoadModelFromMemory(kXml);
  DataPtr d = MakeData(m.get());
  const int c = mj_name2id(m.get(), mjOBJ_BODY, "c");
  mjtNum* qpos = d->qpos + m->jnt_qposadr[m->body_jntadr[c]];
  const Pose want{{0.5, -0.25, 0.125}, QuatNormalized({0.3, 0.1, -0.7, 0.2})};
  PoseToMj(want, qpos, qpos + 3);
  EXPECT_EQ(PoseFromMj(qpos, qpos + 3), want);
  mj_kinematics(m.get(), d.get());
  const Pose got = BodyPose(d.get(), c);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got.pos[i], want.pos[i], 1e-15);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(got.quat[i], want.quat[i], 1e-15);
}

TEST(MjPoseTest, InSubtree) {
  ModelPtr m = LoadModelFromMemory(kXml);
  const int a = mj_name2id(m.get(), mjOBJ_BODY, "a");
  const int b = mj_name2id(m.get(), mjOBJ_BODY, "b");
  const int c = mj_name2id(m.get(), mjOBJ_BODY, "c");
  EXPECT_TRUE(InSubtree(m.get(), b, a));
  EXPECT_TRUE(InSubtree(m.get(), a, a));
  EXPECT_TRUE(InSubtree(m.get(), b, 0));  // the world holds every body
  EXPECT_FALSE(InSubtree(m.get(), a, b));
  EXPECT_FALSE(InSubtree(m.get(), c, a));
}

}  // namespace
}  // namespace mlspaces::sim
