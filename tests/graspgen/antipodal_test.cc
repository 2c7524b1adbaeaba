// Systematic antipodal candidates (src/graspgen/antipodal.cc) on a box, a cylinder and an
// L-bracket OBJ the test writes, with the franka_droid gripper proxy.
#include "mlspaces/graspgen/antipodal.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "graspgen/assets.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/graspgen/generate.h"
#include "mlspaces/robots/robot_spec.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "test_util.h"

namespace mlspaces::graspgen {
namespace {

Vec3 Col(const Mat4& t, int c) { return {t(0, c), t(1, c), t(2, c)}; }
Vec3 At(const Mat4& t, const Vec3& p) {
  return {t(0, 0) * p[0] + t(0, 1) * p[1] + t(0, 2) * p[2] + t(0, 3),
          t(1, 0) * p[0] + t(1, 1) * p[1] + t(1, 2) * p[2] + t(1, 3),
          t(2, 0) * p[0] + t(2, 1) * p[1] + t(2, 2) * p[2] + t(2, 3)};
}

std::string Bytes(const CandidateSet& s) {
  std::string out;
  for (const GraspCandidate& c : s.candidates) {
    out.append(reinterpret_cast<const char*>(c.tcp.m.data()), sizeof(double) * 16);
    out.append(reinterpret_cast<const char*>(&c.quality), sizeof(double));
    out.append(reinterpret_cast<const char*>(&c.depth), sizeof(double));
  }
  return out;
}

TEST(GraspgenAntipodalTest, CandidateSpaceMatchesTheOriginal) {
  const CandidateParams p;
  const std::vector<double> s = Standoffs(p), r = Rolls(p);
  ASSERT_EQ(s.size(), 7u);
  EXPECT_DOUBLE_EQ(s.front(), 0.101);
  EXPECT_DOUBLE_EQ(s.back(), 0.174);
  ASSERT_EQ(r.size(), 12u);
  EXPECT_NEAR(r.back(), 165 * std::numbers::pi / 180, 1e-12);
  // TCP: approach = -normal, fingers along y, origin (standoff - 0.155) out along the normal.
  for (const Vec3& n : {Vec3{0, 0, 1}, Vec3{0, 0, -1}, Vec3{0.6, 0, 0.8}, Vec3{0, -1, 0}}) {
    const Mat4 t = CandidateTcp({0.1, 0.2, 0.3}, n, 0.3, 0.12, 0.155);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(Col(t, 2)[k], -n[k], 1e-12);
    EXPECT_NEAR(t(0, 3), 0.1 - 0.035 * n[0], 1e-12);
    EXPECT_NEAR(t(2, 3), 0.3 - 0.035 * n[2], 1e-12);
    EXPECT_NEAR(Dot(Col(t, 0), Col(t, 1)), 0, 1e-12);
    EXPECT_NEAR(Dot(Col(t, 1), Col(t, 1)), 1, 1e-12);
    // Roll turns the finger axis about the approach by the same angle.
    const Mat4 t2 = CandidateTcp({0.1, 0.2, 0.3}, n, 0.3 + 0.5, 0.12, 0.155);
    EXPECT_NEAR(Dot(Col(t, 1), Col(t2, 1)), std::cos(0.5), 1e-12);
  }
  CandidateParams bad;
  bad.standoff_density = 0;
  EXPECT_THROW(Standoffs(bad), Error);
  bad = {};
  bad.roll_step_deg = -1;
  EXPECT_THROW(Rolls(bad), Error);
  const GripperProxy g = FrankaDroidGripperProxy();
  EXPECT_EQ(g.ray_levels.size(), 20u);
  EXPECT_NEAR(g.finger_offset, 0.0465, 1e-4);  // pads' inner faces 85 mm apart, as the 2F-85
}

// The proxy is franka_droid.xml's open gripper: every gripper geom's box (or a capsule's or
// cylinder's bounding box) at qpos0, in the grasp_site frame, is one of the proxy's boxes.
TEST(GraspgenAntipodalTest, GripperProxyMatchesFrankaDroidXml) {
  const sim::ModelPtr m = sim::ComposeAndCompile(std::string(MLSPACES_SOURCE_DIR) +
                                                 "/assets/robots/franka_droid/franka_droid.xml");
  const sim::DataPtr d(mj_makeData(m.get()));
  mj_kinematics(m.get(), d.get());
  const int site = mj_name2id(m.get(), mjOBJ_SITE, "gripper/grasp_site");
  ASSERT_GE(site, 0);
  Rot3 sr;
  std::copy_n(d->site_xmat + 9 * site, 9, sr.begin());
  const Mat4 site_inv = InverseRigid(ToMat4(
      Vec3{d->site_xpos[3 * site], d->site_xpos[3 * site + 1], d->site_xpos[3 * site + 2]}, sr));
  const GripperProxy g = FrankaDroidGripperProxy();
  int matched = 0;
  for (int geom = 0; geom < m->ngeom; ++geom) {
    const std::string name =
        mj_id2name(m.get(), mjOBJ_GEOM, geom) ? mj_id2name(m.get(), mjOBJ_GEOM, geom) : "";
    if (name.rfind("gripper/", 0) != 0) continue;
    Rot3 gr;
    std::copy_n(d->geom_xmat + 9 * geom, 9, gr.begin());
    const Mat4 t = site_inv * ToMat4(Vec3{d->geom_xpos[3 * geom], d->geom_xpos[3 * geom + 1],
                                          d->geom_xpos[3 * geom + 2]},
                                     gr);
    const double* size = m->geom_size + 3 * geom;
    Vec3 half{size[0], size[1], size[2]};
    if (m->geom_type[geom] == mjGEOM_CYLINDER) half = {size[0], size[0], size[1]};
    if (m->geom_type[geom] == mjGEOM_CAPSULE) half = {size[0], size[0], size[1] + size[0]};
    bool found = false;
    for (const OrientedBox& b : g.boxes) {
      bool same = true;
      double axis = 0;  // the box's z axis is the geom's, up to sign (capsule, cylinder axes)
      for (int k = 0; k < 3; ++k) {
        same =
            same && std::abs(b.center[k] - t(k, 3)) < 1e-6 && std::abs(b.half[k] - half[k]) < 1e-6;
        axis += b.rot[3 * k + 2] * t(k, 2);
      }
      same = same && std::abs(std::abs(axis) - 1) < 1e-9;
      found = found || same;
    }
    EXPECT_TRUE(found) << name;
    matched += found;
  }
  EXPECT_EQ(matched, static_cast<int>(g.boxes.size()));
}

// Any robot's open gripper from its robot.yaml and MJCF: a box per collision geom below the
// gripper body, the closing rays at the pads' centres, whose inner faces are as far apart as
// the robot's open fingers (robot.yaml finger_range, which inspect-robot measures by closing
// the gripper in simulation), at 20 levels within the pads' length.
TEST(GraspgenAntipodalTest, GripperProxyOfEachRobotOpensAsWideAsItsFingers) {
  for (const char* name : {"franka_droid", "xarm7"}) {
    SCOPED_TRACE(name);
    const robots::RobotSpec robot = robots::LoadRobotSpec(name);
    const GripperProxy g = GripperProxyOf(robot);
    EXPECT_EQ(g.name, name);

    const sim::ModelPtr m = sim::ComposeAndCompile(robot.xml);
    const sim::DataPtr d(mj_makeData(m.get()));
    mj_kinematics(m.get(), d.get());
    const int root = mj_name2id(m.get(), mjOBJ_BODY, robot.gripper_body.c_str());
    const int site = mj_name2id(m.get(), mjOBJ_SITE, robot.tcp_site.c_str());
    ASSERT_GE(root, 0);
    ASSERT_GE(site, 0);
    size_t colliding = 0;
    for (int geom = 0; geom < m->ngeom; ++geom) {
      int b = m->geom_bodyid[geom];
      while (b > 0 && b != root) b = m->body_parentid[b];
      colliding += b == root && (m->geom_contype[geom] != 0 || m->geom_conaffinity[geom] != 0);
    }
    EXPECT_EQ(g.boxes.size(), colliding);

    // Each pad's centre and half thickness across the closing direction (the site's y), and
    // its half length along the approach (the site's z).
    double gap = 0, offset = 0, lo = -1e9, hi = 1e9;
    for (const std::string& pad_name : robot.finger_pads) {
      const int pad = mj_name2id(m.get(), mjOBJ_GEOM, pad_name.c_str());
      ASSERT_EQ(m->geom_type[pad], mjGEOM_BOX) << pad_name;
      double centre[3] = {0, 0, 0}, reach[3] = {0, 0, 0};
      for (int i = 0; i < 3; ++i) {  // site axis i
        for (int k = 0; k < 3; ++k) {
          centre[i] += d->site_xmat[9 * site + 3 * k + i] *
                       (d->geom_xpos[3 * pad + k] - d->site_xpos[3 * site + k]);
          double along = 0;  // site axis i . geom axis k
          for (int r = 0; r < 3; ++r) {
            along += d->site_xmat[9 * site + 3 * r + i] * d->geom_xmat[9 * pad + 3 * r + k];
          }
          reach[i] += std::abs(along) * m->geom_size[3 * pad + k];
        }
      }
      gap += std::abs(centre[1]) - reach[1];
      offset += std::abs(centre[1]);
      lo = std::max(lo, centre[2] - reach[2]);
      hi = std::min(hi, centre[2] + reach[2]);
    }
    EXPECT_NEAR(gap, robot.finger_range[1], 0.002);
    EXPECT_NEAR(g.finger_offset, offset / 2, 1e-9);
    ASSERT_EQ(g.ray_levels.size(), 20u);
    EXPECT_NEAR(g.ray_levels.front(), lo, 1e-9);
    EXPECT_NEAR(g.ray_levels.back(), hi, 1e-9);
  }
}

TEST(GraspgenAntipodalTest, GripperProxyOfABadRobotNamesTheField) {
  const robots::RobotSpec xarm7 = robots::LoadRobotSpec("xarm7");
  robots::RobotSpec same_side = xarm7;
  same_side.finger_pads[1] = same_side.finger_pads[0];
  mlspaces::testing::ExpectError([&] { GripperProxyOf(same_side); },
                                 {"robot.yaml", "gripper.finger_pads", "do not face each other"});
  robots::RobotSpec closed = xarm7;
  closed.finger_range[1] = 0.2;  // as if qpos0 were a hand closed to under a fifth of that
  mlspaces::testing::ExpectError([&] { GripperProxyOf(closed); },
                                 {"robot.yaml", "gripper.finger_range",
                                  "not open at the MJCF's "
                                  "qpos0: its pads' inner faces are 85 mm apart",
                                  "opens them 200 mm"});
  robots::RobotSpec no_site = xarm7;
  no_site.tcp_site = "gripper/nope";
  mlspaces::testing::ExpectError([&] { GripperProxyOf(no_site); },
                                 {"robot.yaml", "tcp_site", "no site 'gripper/nope'"});
  robots::RobotSpec outside = xarm7;
  const sim::ModelPtr m = sim::ComposeAndCompile(xarm7.xml);
  for (int geom = 0; geom < m->ngeom; ++geom) {  // any geom of the arm, not the gripper
    const char* gname = mj_id2name(m.get(), mjOBJ_GEOM, geom);
    if (gname != nullptr && std::string(gname).rfind("gripper/", 0) != 0) {
      outside.finger_pads[0] = gname;
      break;
    }
  }
  mlspaces::testing::ExpectError([&] { GripperProxyOf(outside); },
                                 {"gripper.finger_pads", "is not below gripper/base"});
}

// inspect-robot's last line: CheckGraspGeneration catches GripperProxyOf's error, and the CLI
// prints it (a robot that cannot give grasps is not one of its problems).
TEST(GraspgenAntipodalTest, InspectRobotSaysWhetherGraspsCanBeGenerated) {
  using ::testing::HasSubstr;
  const robots::RobotSpec xarm7 = robots::LoadRobotSpec("xarm7");
  const GraspReadiness ready = CheckGraspGeneration(xarm7);
  ASSERT_TRUE(ready.ready) << ready.problem;
  EXPECT_TRUE(ready.on_search_path);
  EXPECT_EQ(ready.gripper.boxes.size(), GripperProxyOf(xarm7).boxes.size());
  const Json j = ToJson(ready);
  EXPECT_EQ(j["ready"], true);
  EXPECT_EQ(j["gripper_boxes"], ready.gripper.boxes.size());
  EXPECT_DOUBLE_EQ(j["finger_offset"].get<double>(), ready.gripper.finger_offset);
  EXPECT_FALSE(j.contains("problem"));
  const std::string line = FormatGraspReadiness(ready, "xarm7");
  EXPECT_THAT(line, ::testing::StartsWith("grasp generation: ready ("));
  EXPECT_THAT(line, ::testing::EndsWith("): mlspaces generate-grasps --robot xarm7\n"));

  robots::RobotSpec closed = xarm7;
  closed.finger_range[1] = 0.2;
  const GraspReadiness not_ready = CheckGraspGeneration(closed);
  EXPECT_FALSE(not_ready.ready);
  EXPECT_THAT(not_ready.problem, HasSubstr("gripper.finger_range"));
  EXPECT_EQ(FormatGraspReadiness(not_ready, "xarm7"),
            "grasp generation: not possible: " + not_ready.problem + "\n");
  EXPECT_EQ(ToJson(not_ready)["problem"], not_ready.problem);

  // The CLI, on copies of franka_droid given by path: off the search path it says how to put
  // the robot there; with the hand's open gap wrong it says why not, as JSON too.
  namespace fs = std::filesystem;
  mlspaces::testing::TempDir tmp;
  const fs::path bundled = fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid";
  const fs::path copy = tmp.path() / "mine/franka_droid";
  fs::create_directories(copy.parent_path());
  fs::copy(bundled, copy, fs::copy_options::recursive);
  mlspaces::testing::CliResult cli =
      mlspaces::testing::RunCli({"inspect-robot", copy.string(), "--no-ik"});
  EXPECT_EQ(cli.exit_code, 0) << cli.err;
  EXPECT_THAT(cli.out, HasSubstr("\nproblems: none\ngrasp generation: ready ("));
  EXPECT_THAT(cli.out, HasSubstr("--robot franka_droid (once its folder's parent is on "
                                 "$MLSPACES_ROBOT_PATH)\n"));
  cli = mlspaces::testing::RunCli(
      {"inspect-robot", copy.string(), "--no-ik"},
      "env " + mlspaces::testing::ShellQuote("MLSPACES_ROBOT_PATH=" + copy.parent_path().string()) +
          " ");
  EXPECT_EQ(cli.exit_code, 0) << cli.err;
  EXPECT_THAT(cli.out, HasSubstr("--robot franka_droid\n")) << cli.out;

  std::string yaml = mlspaces::testing::Slurp(copy / "robot.yaml");
  const std::string range = "finger_range: [0.0, 0.085]";
  ASSERT_NE(yaml.find(range), std::string::npos);
  yaml.replace(yaml.find(range), range.size(), "finger_range: [0.0, 0.2]");
  mlspaces::testing::WriteText(copy / "robot.yaml", yaml);
  cli = mlspaces::testing::RunCli({"inspect-robot", copy.string(), "--no-ik", "--json"});
  EXPECT_EQ(cli.exit_code, 1) << cli.err;  // the gripper travel check: finger_range is wrong
  const Json report = ParseJson(cli.out, "stdout");
  EXPECT_EQ(report["grasp_generation"]["ready"], false);
  EXPECT_THAT(report["grasp_generation"]["problem"].get<std::string>(),
              ::testing::AllOf(HasSubstr((copy / "robot.yaml").string()),
                               HasSubstr("gripper.finger_range"), HasSubstr("not open")));
}

TEST(GraspgenAntipodalTest, BoxCandidatesStraddleTheBoxOnOppositeFaces) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(AssetCollisionMesh(testing::WriteBoxAsset(dir.path())));  // +-.02 .025 .04
  const GripperProxy g = FrankaDroidGripperProxy();
  CandidateParams p;
  const CandidateSet set = GenerateCandidates(bvh, g, p, 11);
  const size_t points = static_cast<size_t>(std::ceil(bvh.mesh().Area() / p.surface_density));
  EXPECT_EQ(set.stats.points, points);
  EXPECT_EQ(set.stats.raw, points * 7 * 12);
  EXPECT_EQ(set.stats.visible, set.stats.raw);  // convex: nothing hides a point
  EXPECT_LT(set.stats.collision_free, set.stats.visible);
  EXPECT_EQ(set.stats.kept, set.candidates.size());
  ASSERT_GT(set.candidates.size(), 1000u);
  const double half[3] = {0.02, 0.025, 0.04};
  auto inside = [&](const Vec3& q) {
    return std::abs(q[0]) < half[0] && std::abs(q[1]) < half[1] && std::abs(q[2]) < half[2];
  };
  int opposite = 0;
  for (const GraspCandidate& c : set.candidates) {
    ASSERT_GE(c.quality, p.min_quality);
    ASSERT_LE(c.quality, 1 + 1e-12);
    ASSERT_GE(c.depth, 0);
    ASSERT_LE(c.depth, 1);
    EXPECT_FALSE(HandCollides(bvh, g, c.tcp));
    // Both finger pads are outside the box and the closing line between them crosses it.
    const Vec3 y = Col(c.tcp, 1);
    bool crossed = false;
    for (double z : g.ray_levels) {
      const Vec3 left = At(c.tcp, {0, g.finger_offset, z}),
                 right = At(c.tcp, {0, -g.finger_offset, z});
      ASSERT_FALSE(inside(left));
      ASSERT_FALSE(inside(right));
      const auto hl = bvh.Raycast(left, {-y[0], -y[1], -y[2]}, 2 * g.finger_offset);
      const auto hr = bvh.Raycast(right, y, 2 * g.finger_offset);
      if (!hl || !hr) continue;
      crossed = true;
      const double nn = Dot(FaceNormal(bvh.mesh(), hl->face), FaceNormal(bvh.mesh(), hr->face));
      // Good grasps (cosine > 1/sqrt 2) close on two opposite faces.
      if (c.quality > 0.75) {
        EXPECT_NEAR(nn, -1, 1e-9);
      }
    }
    EXPECT_TRUE(crossed);
    opposite += c.quality > 0.999;
  }
  EXPECT_GT(opposite, 100);  // straight across the box
  // All three extents (4, 5 and 8 cm) fit the 85 mm opening: every face has candidates.
  bool face_seen[6] = {};
  for (const GraspCandidate& c : set.candidates) {
    for (int k = 0; k < 3; ++k) {
      if (std::abs(c.normal[k]) > 0.5) face_seen[2 * k + (c.normal[k] > 0)] = true;
    }
  }
  for (bool seen : face_seen) EXPECT_TRUE(seen);
}

TEST(GraspgenAntipodalTest, DeterministicForASeedWhateverTheThreads) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(AssetCollisionMesh(testing::WriteCylinderAsset(dir.path())));
  const GripperProxy g = FrankaDroidGripperProxy();
  CandidateParams p;
  p.surface_density = 1e-4;
  p.threads = 1;
  const std::string one = Bytes(GenerateCandidates(bvh, g, p, 5));
  p.threads = 2;
  const CandidateSet two = GenerateCandidates(bvh, g, p, 5);
  EXPECT_EQ(Bytes(two), one);
  EXPECT_NE(Bytes(GenerateCandidates(bvh, g, p, 6)), one);
  ASSERT_GT(two.candidates.size(), 100u);
  for (const GraspCandidate& c : two.candidates) {
    EXPECT_GE(c.quality, 0.005);
    EXPECT_LE(c.quality, 1 + 1e-12);
  }
}

TEST(GraspgenAntipodalTest, CylinderSideGraspsCloseAcrossTheAxis) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(AssetCollisionMesh(testing::WriteCylinderAsset(dir.path())));
  CandidateParams p;
  p.surface_density = 1e-4;
  const CandidateSet set = GenerateCandidates(bvh, FrankaDroidGripperProxy(), p, 3);
  // The axis is the body's y (a child body turned about x, at z 0.01). Grasps from the side
  // with fingers across the axis are good; with fingers along the 10 cm axis, too long to fit.
  int across = 0;
  for (const GraspCandidate& c : set.candidates) {
    const Vec3 y = Col(c.tcp, 1);
    if (std::abs(c.normal[1]) < 0.1) {
      EXPECT_LT(std::abs(y[1]), 0.9) << "fingers along the 10 cm axis cannot close on it";
      across += std::abs(y[1]) < 0.1 && c.quality > 0.9;
    }
  }
  EXPECT_GT(across, 20);
}

TEST(GraspgenAntipodalTest, LBracketGetsCandidatesOnBothLegs) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(AssetCollisionMesh(testing::WriteLBracketAsset(dir.path())));
  CandidateParams p;
  const CandidateSet set = GenerateCandidates(bvh, FrankaDroidGripperProxy(), p, 9);
  EXPECT_EQ(set.stats.points, static_cast<size_t>(std::ceil(0.01275 / 2.5e-5)));
  EXPECT_EQ(set.stats.raw, set.stats.points * 84);
  int foot = 0, wall = 0;  // fingers closing across the foot's / the wall's 15 mm thickness
  for (const GraspCandidate& c : set.candidates) {
    const Vec3 y = Col(c.tcp, 1);
    if (c.quality > 0.99 && std::abs(y[2]) > 0.99 && c.point[0] > 0.03) ++foot;
    if (c.quality > 0.99 && std::abs(y[0]) > 0.99 && c.point[2] > 0.03) ++wall;
  }
  EXPECT_GT(foot, 20);
  EXPECT_GT(wall, 20);
}

TEST(GraspgenAntipodalTest, UChannelVisibilityRemovesHiddenApproaches) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(
      AssetCollisionMesh(testing::WriteObjAsset(dir.path(), "channel", testing::UChannelObj())));
  CandidateParams p;
  p.surface_density = 1e-4;
  const CandidateSet set = GenerateCandidates(bvh, FrankaDroidGripperProxy(), p, 4);
  // The inner wall faces (x = 0.015 facing +x, x = 0.065 facing -x, above the floor) see the
  // other wall 0.05 m away, nearer than the smallest standoff: all their candidates go.
  size_t inner = 0;
  const SurfaceSamples s = SampleSurface(bvh.mesh(), p.surface_density, 4);
  for (size_t i = 0; i < s.points.size(); ++i) {
    const Vec3 &q = s.points[i], &n = s.normals[i];
    inner += (std::abs(q[0] - 0.015) < 1e-6 && n[0] > 0.5) ||
             (std::abs(q[0] - 0.065) < 1e-6 && n[0] < -0.5);
  }
  ASSERT_GT(inner, 10u);
  EXPECT_EQ(set.stats.visible, set.stats.raw - inner * 84);
  for (const GraspCandidate& c : set.candidates) {
    EXPECT_FALSE(std::abs(c.normal[0]) > 0.5 && c.point[0] > 0.01 && c.point[0] < 0.07)
        << "a candidate on an inner wall";
  }
  EXPECT_GT(set.candidates.size(), 100u);
}

}  // namespace
}  // namespace mlspaces::graspgen
