// Grasp selection (src/datagen/grasp_selection.cc): the original's ranking cost against a
// hand-computed ordering, the selection pipeline, and the open-gripper collision probe on the
// tutorial scene (examples/custom_assets: floor + red block) with franka_droid inserted.
#include "mlspaces/datagen/grasp_selection.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "mlspaces/core/se3.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/scene.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
const fs::path kRobot =
    fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid/franka_droid.xml";
const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";
constexpr double kPi = 3.14159265358979323846;
const std::vector<double> kHome = {0, -0.7853, 0, -2.35619, 0, 1.57079, 0};

// Rotation from its three columns, at position p.
Mat4 Frame(Vec3 x, Vec3 y, Vec3 z, Vec3 p) {
  Mat4 t;
  for (int r = 0; r < 3; ++r) {
    t(r, 0) = x[r];
    t(r, 1) = y[r];
    t(r, 2) = z[r];
    t(r, 3) = p[r];
  }
  return t;
}

// Top-down: x = (1,0,0), y = (0,-1,0), z = (0,0,-1) (the tutorial's grasp frame).
Mat4 TopDown(Vec3 p) { return Frame({1, 0, 0}, {0, -1, 0}, {0, 0, -1}, p); }

TEST(GraspRankingTest, ReproducesHandComputedOrdering) {
  const Mat4 tcp = TopDown({0.3, 0.0, 0.5});
  const Mat4 object = Frame({1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.4, 0.0, 0.025});
  const Mat4 a = TopDown({0.4, 0.0, 0.025});                                   // on the object
  const Mat4 b = Frame({-1, 0, 0}, {0, 1, 0}, {0, 0, -1}, {0.4, 0.0, 0.025});  // a's flip
  const Mat4 c = Frame({0, 0, -1}, {0, 1, 0}, {1, 0, 0}, {0.4, 0.0, 0.025});   // side, +x
  const Mat4 d = TopDown({0.42, 0.0, 0.025});                                  // 2 cm off
  // By hand: |p(T^-1 G)| + 0.01 deg + 2 G[2,2] + 8 |p(O^-1 G)|.
  const double da = std::sqrt(0.1 * 0.1 + 0.475 * 0.475);
  const double dd = std::sqrt(0.12 * 0.12 + 0.475 * 0.475);
  // c vs tcp: trace(R_T^T R_c) = sum of column dots (0,0,-1).(1,0,0) + (0,1,0).(0,-1,0) +
  // (1,0,0).(0,0,-1) = -1, so the angle is acos((-1 - 1) / 2) = 180 deg.
  const double angle_c = std::acos((-1.0 - 1.0) / 2.0) * 180.0 / kPi;  // 180 deg
  const double expect[4] = {da - 2.0, da + 0.01 * 180.0 - 2.0, da + 0.01 * angle_c + 0.0,
                            dd - 2.0 + 8.0 * 0.02};
  const std::vector<Mat4> grasps = {c, b, a, d};
  const double got[4] = {GraspCost(a, tcp, object), GraspCost(b, tcp, object),
                         GraspCost(c, tcp, object), GraspCost(d, tcp, object)};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(got[i], expect[i], 1e-9) << i;
  // a (-1.5146) < d (-1.3501) < b (0.2854) < c (2.2854); indices into {c, b, a, d}.
  EXPECT_EQ(RankGrasps(grasps, tcp, object), (std::vector<size_t>{2, 3, 1, 0}));
  EXPECT_EQ(RankGrasps(grasps, tcp, object, 2), (std::vector<size_t>{2, 3}));
  // Ties keep input order (stable argsort).
  const std::vector<Mat4> ties = {d, a, a, d};
  EXPECT_EQ(RankGrasps(ties, tcp, object), (std::vector<size_t>{1, 2, 0, 3}));
  // Weights are honoured: with no top-down reward and a heavy angle term, a's flip is last.
  GraspCostWeights w;
  w.approach_z = 0;
  w.tcp_angle_deg = 1.0;
  EXPECT_EQ(RankGrasps(grasps, tcp, object, 512, w).back(), 1u);
}

TEST(GraspRankingTest, SelectGraspFiltersThenTakesFirstFeasible) {
  const Mat4 tcp = TopDown({0.3, 0.0, 0.5});
  const Mat4 object = Frame({1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.4, 0.0, 0.025});
  const std::vector<Mat4> grasps = {TopDown({0.42, 0, 0.025}), TopDown({0.4, 0, 0.025}),
                                    TopDown({0.45, 0, 0.025})};
  // Costs order: 1, 0, 2. Collision rejects 1, IK rejects 0 -> 2.
  int ik_calls = 0;
  const GraspSelection s = SelectGrasp(
      grasps, tcp, object, [](const Mat4& g) { return std::abs(g(0, 3) - 0.4) > 1e-9; },
      [&](const Mat4& g) {
        ++ik_calls;
        return std::abs(g(0, 3) - 0.42) > 1e-9;
      });
  ASSERT_TRUE(s.index.has_value());
  EXPECT_EQ(*s.index, 2u);
  EXPECT_EQ(s.ranked, (std::vector<size_t>{1, 0, 2}));
  EXPECT_EQ(s.num_collision_free, 2u);
  EXPECT_EQ(s.num_ik_checked, 2u);
  EXPECT_EQ(ik_calls, 2);
  // IK checks are capped; nothing feasible -> no index.
  GraspSelectionOptions options;
  options.max_ik_checked = 1;
  const GraspSelection none = SelectGrasp(
      grasps, tcp, object, nullptr, [](const Mat4&) { return false; }, options);
  EXPECT_FALSE(none.index.has_value());
  EXPECT_EQ(none.num_collision_free, 3u);
  EXPECT_EQ(none.num_ik_checked, 1u);
}

// The tutorial scene with franka_droid at the origin, at home, gripper open.
class GraspProbeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_.emplace(sim::Scene::Load(kExample / "scene.xml"));
    scene_->InsertRobot(kRobot, "robot_0/", Pose{});
    model_ = scene_->Compile();
    data_ = sim::MakeData(model_.get());
    for (int i = 0; i < 7; ++i) {
      const std::string name = "robot_0/fr3_joint" + std::to_string(i + 1);
      data_->qpos[model_->jnt_qposadr[mj_name2id(model_.get(), mjOBJ_JOINT, name.c_str())]] =
          kHome[i];
    }
    mj_forward(model_.get(), data_.get());
    block_ = mj_name2id(model_.get(), mjOBJ_BODY, "red_block");
    ASSERT_GE(block_, 0);

    registry_.RegisterAssetLibrary("custom_assets", kExample / "asset_library");
    registry_.RegisterGraspLibrary("custom_grasps", kExample / "asset_library", "custom_assets");
  }

  Mat4 BlockPose() const { return ToMat4(sim::BodyPose(data_.get(), block_)); }

  std::vector<Mat4> LibraryGraspsInWorld() const {
    const GraspSet set = registry_.LoadGrasps({"red_block"});
    return GraspsInWorld(BlockPose(), set.poses, /*include_flipped=*/true);
  }

  std::string GeomName(int g) const { return sim::MjName(model_.get(), mjOBJ_GEOM, g); }

  std::optional<sim::Scene> scene_;
  sim::ModelPtr model_;
  sim::DataPtr data_;
  int block_ = -1;
  Registry registry_;
};

TEST_F(GraspProbeTest, LibraryTopDownGraspOnRedBlockIsCleanAndShiftedOnesCollide) {
  for (ProbeShape shape : {ProbeShape::kGripperGeoms, ProbeShape::kMolmoSpacesProxy}) {
    SCOPED_TRACE(shape == ProbeShape::kGripperGeoms ? "gripper geoms" : "original proxy");
    GraspProbeOptions options;
    options.shape = shape;
    GraspCollisionChecker checker(scene_->composer(), model_.get(), options);
    checker.SyncState(data_.get());
    const std::vector<double> qpos_before(data_->qpos, data_->qpos + model_->nq);

    const std::vector<Mat4> grasps = LibraryGraspsInWorld();
    ASSERT_EQ(grasps.size(), 2u);  // the grasp and its flip
    EXPECT_NEAR(grasps[0](2, 2), -1.0, 1e-12);
    EXPECT_EQ(checker.NonCollidingMask(grasps), (std::vector<bool>{true, true}));

    // Lowered 3 cm: the fingertips go through the floor.
    Mat4 low = grasps[0];
    low(2, 3) -= 0.03;
    const auto low_contacts = checker.Contacts(low);
    ASSERT_FALSE(low_contacts.empty());
    bool floor = false;
    for (const ProbeContact& c : low_contacts) floor |= GeomName(c.sim_geom) == "floor";
    EXPECT_TRUE(floor);

    // Shifted 3 cm along the finger axis: one finger inside the block.
    Mat4 side = grasps[0];
    side(1, 3) += 0.03;
    const auto side_contacts = checker.Contacts(side);
    ASSERT_FALSE(side_contacts.empty());
    bool block = false;
    for (const ProbeContact& c : side_contacts) block |= GeomName(c.sim_geom) == "red_block_geom";
    EXPECT_TRUE(block);
    EXPECT_LT(side_contacts.front().dist, 0.0);

    // The episode's data is untouched.
    EXPECT_EQ(qpos_before, std::vector<double>(data_->qpos, data_->qpos + model_->nq));
    // The sim model's layout is a prefix of the probe model's.
    EXPECT_EQ(checker.probe_model()->nq, model_->nq + 7);
    EXPECT_EQ(checker.probe_model()->ngeom, model_->ngeom + checker.num_probe_geoms());
  }
}

TEST_F(GraspProbeTest, FollowsTheEpisodeStateAfterSync) {
  GraspCollisionChecker checker(scene_->composer(), model_.get());
  checker.SyncState(data_.get());
  Mat4 side = LibraryGraspsInWorld()[0];
  side(1, 3) += 0.03;
  EXPECT_TRUE(checker.Collides(side));
  // Move the block 20 cm along x in the episode; the old spot is now free, the new one not.
  const int jnt = model_->body_jntadr[block_];
  data_->qpos[model_->jnt_qposadr[jnt]] += 0.2;
  mj_forward(model_.get(), data_.get());
  EXPECT_TRUE(checker.Collides(side));  // not synced yet
  checker.SyncState(data_.get());
  EXPECT_FALSE(checker.Collides(side));
  Mat4 moved = side;
  moved(0, 3) += 0.2;
  EXPECT_TRUE(checker.Collides(moved));
  const Mat4 clean = LibraryGraspsInWorld()[0];
  EXPECT_NEAR(clean(0, 3), 0.6, 1e-9);
  EXPECT_FALSE(checker.Collides(clean));
}

TEST_F(GraspProbeTest, RobotGeomsOptional) {
  // A probe at the current TCP overlaps the robot's own gripper.
  const int site = mj_name2id(model_.get(), mjOBJ_SITE, "robot_0/gripper/grasp_site");
  const Mat4 tcp = sim::SiteMat4(data_.get(), site);
  GraspCollisionChecker with_robot(scene_->composer(), model_.get());
  with_robot.SyncState(data_.get());
  const auto contacts = with_robot.Contacts(tcp);
  ASSERT_FALSE(contacts.empty());
  EXPECT_TRUE(GeomName(contacts.front().sim_geom).starts_with("robot_0/"));
  GraspProbeOptions options;
  options.collide_with_robot = false;
  GraspCollisionChecker without_robot(scene_->composer(), model_.get(), options);
  without_robot.SyncState(data_.get());
  EXPECT_FALSE(without_robot.Collides(tcp));
}

TEST_F(GraspProbeTest, ClearanceAndErrors) {
  // The clean grasp's pads are 17.5 mm from the block faces: 2 cm clearance flags it.
  GraspProbeOptions options;
  options.clearance = 0.02;
  GraspCollisionChecker checker(scene_->composer(), model_.get(), options);
  checker.SyncState(data_.get());
  EXPECT_TRUE(checker.Collides(LibraryGraspsInWorld()[0]));
  GraspProbeOptions bad;
  bad.gripper_body = "robot_0/no_such_body";
  EXPECT_THROW(GraspCollisionChecker(scene_->composer(), model_.get(), bad), Error);
}

TEST_F(GraspProbeTest, MicrosecondsPerCandidate) {
  GraspCollisionChecker checker(scene_->composer(), model_.get());
  checker.SyncState(data_.get());
  std::vector<Mat4> candidates;
  const Mat4 g = LibraryGraspsInWorld()[0];
  for (int k = 0; k < 512; ++k) {
    Mat4 c = g * RotZ(0.01 * k);
    c(1, 3) += 0.0002 * (k % 200);  // a mix of clean and colliding candidates
    candidates.push_back(c);
  }
  const auto t0 = std::chrono::steady_clock::now();
  size_t clean = 0;
  for (int rep = 0; rep < 4; ++rep) {
    for (bool ok : checker.NonCollidingMask(candidates)) clean += ok;
  }
  const double us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() /
      (4.0 * candidates.size());
  std::printf("[probe] %.2f us per candidate (%d probe geoms, %zu/%zu clean)\n", us,
              checker.num_probe_geoms(), clean / 4, candidates.size());
  EXPECT_GT(clean, 0u);
  EXPECT_LT(clean, 4 * candidates.size());
  // The time per candidate is a figure (printed above; bench/ has the benchmark), not a verdict.
}

}  // namespace
}  // namespace mlspaces::datagen
