// MuJoCo's pose arrays <-> Pose / Mat4 (src/sim/mj_pose.cc), InSubtree and CollisionGeoms.
#include "mlspaces/sim/mj_pose.h"

#include <algorithm>
#include <string>
#include <vector>

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

// A tetrahedron's bounding box is not centred on the mesh frame (MuJoCo puts that at the
// mesh's centroid, along its principal axes): the box frame holds every vertex and touches
// each of its six faces.
TEST(MjPoseTest, GeomBoxFrameHoldsTheGeomTightly) {
  ModelPtr m = LoadModelFromMemory(R"(<mujoco>
  <asset><mesh name="tet" vertex="0 0 0  0.3 0 0  0 0.2 0  0 0 0.1"/></asset>
  <worldbody><body pos="0.5 -0.2 0.7" euler="20 -35 60">
    <geom name="t" type="mesh" mesh="tet" pos="0.01 0.02 0.03" euler="5 10 15"/>
  </body></worldbody></mujoco>)");
  DataPtr d = MakeData(m.get());
  mj_kinematics(m.get(), d.get());
  const int g = mj_name2id(m.get(), mjOBJ_GEOM, "t");
  Vec3 half;
  const Mat4 box = GeomBoxFrame(m.get(), d.get(), g, &half);
  const Mat4 inv = InverseRigid(box);
  const Mat4 geom = GeomMat4(d.get(), g);
  const int mesh = m->geom_dataid[g];
  Vec3 lo{1, 1, 1}, hi{-1, -1, -1};
  for (int v = 0; v < m->mesh_vertnum[mesh]; ++v) {
    const float* p = m->mesh_vert + 3 * (m->mesh_vertadr[mesh] + v);  // geom frame
    Vec3 world{}, in_box{};
    for (int r = 0; r < 3; ++r)
      world[r] = geom(r, 3) + geom(r, 0) * p[0] + geom(r, 1) * p[1] + geom(r, 2) * p[2];
    for (int r = 0; r < 3; ++r)
      in_box[r] = inv(r, 3) + inv(r, 0) * world[0] + inv(r, 1) * world[1] + inv(r, 2) * world[2];
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], in_box[k]);
      hi[k] = std::max(hi[k], in_box[k]);
    }
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(lo[k], -half[k], 1e-6) << k;
    EXPECT_NEAR(hi[k], half[k], 1e-6) << k;
  }
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

TEST(MjPoseTest, CollisionGeomsOfASubtreeLeaveOutVisualGeoms) {
  ModelPtr m = LoadModelFromMemory(R"(<mujoco><worldbody>
    <body name="a">
      <geom name="a_col" size=".1"/>
      <geom name="a_vis" size=".1" contype="0" conaffinity="0"/>
      <body name="b">
        <geom name="b_type" size=".1" conaffinity="0"/>
        <geom name="b_aff" size=".1" contype="0" conaffinity="2"/>
      </body>
    </body>
    <body name="c"><geom name="c_col" size=".1"/></body>
  </worldbody></mujoco>)");
  auto ids = [&](const std::vector<std::string>& names) {
    std::vector<int> out;
    out.reserve(names.size());
    for (const std::string& n : names) out.push_back(mj_name2id(m.get(), mjOBJ_GEOM, n.c_str()));
    return out;
  };
  const auto body = [&](const char* name) { return mj_name2id(m.get(), mjOBJ_BODY, name); };
  EXPECT_EQ(CollisionGeoms(m.get(), body("a")), ids({"a_col", "b_type", "b_aff"}));
  EXPECT_EQ(CollisionGeoms(m.get(), body("b")), ids({"b_type", "b_aff"}));
  EXPECT_EQ(CollisionGeoms(m.get(), 0), ids({"a_col", "b_type", "b_aff", "c_col"}));
}

}  // namespace
}  // namespace mlspaces::sim
