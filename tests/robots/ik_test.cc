// Damped-least-squares IK (src/datagen/ik.cc) on the franka_droid arm: random reachable poses
// (FK of random joint configurations within the limits) from the home seed, joint limits,
// unreachable targets, determinism, and that the episode's data is never touched.
#include "mlspaces/robots/ik.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::robots {
namespace {

namespace fs = std::filesystem;
const fs::path kRobot =
    fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid/franka_droid.xml";
const std::vector<double> kHome = {0, -0.7853, 0, -2.35619, 0, 1.57079, 0};
const char* kScene = R"(<mujoco model="ik_test">
  <option timestep="0.002" integrator="implicit"/>
  <worldbody><geom name="floor" type="plane" size="2 2 0.1"/></worldbody>
</mujoco>)";

std::vector<std::string> ArmJoints() {
  std::vector<std::string> names;
  for (int i = 1; i <= 7; ++i) names.push_back("robot_0/fr3_joint" + std::to_string(i));
  return names;
}

class IkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    sim::MjcfComposer composer =
        sim::MjcfComposer::FromString(kScene, fs::path(MLSPACES_SOURCE_DIR) / "ik_scene.xml");
    // A raised, yawed base so the world frame is not the base frame.
    Pose base;
    base.pos = {0.1, -0.2, 0.05};
    base.quat = {std::cos(0.15), 0, 0, std::sin(0.15)};
    composer.Attach(kRobot, "world", "robot_0/", base);
    model_ = composer.Compile();
    data_ = sim::MakeData(model_.get());
    const auto joints = ArmJoints();
    for (size_t i = 0; i < joints.size(); ++i) {
      const int j = mj_name2id(model_.get(), mjOBJ_JOINT, joints[i].c_str());
      data_->qpos[model_->jnt_qposadr[j]] = kHome[i];
    }
    mj_forward(model_.get(), data_.get());
  }

  IkSolver MakeSolver(IkOptions options = {}) {
    const auto joints = ArmJoints();
    IkSolver solver(model_.get(), "robot_0/gripper/grasp_site", joints, kHome, options);
    solver.SyncState(data_.get());
    return solver;
  }

  // Random configurations within the limits, fixed seed.
  std::vector<std::vector<double>> RandomConfigs(IkSolver& solver, int n, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<std::vector<double>> out;
    for (int k = 0; k < n; ++k) {
      std::vector<double> q(7);
      for (int i = 0; i < 7; ++i) {
        q[i] = solver.lower()[i] + u(rng) * (solver.upper()[i] - solver.lower()[i]);
      }
      out.push_back(q);
    }
    return out;
  }

  sim::ModelPtr model_;
  sim::DataPtr data_;
};

TEST_F(IkTest, HomeTargetConvergesImmediately) {
  IkSolver solver = MakeSolver();
  const Mat4 home = solver.Forward(kHome);
  const IkResult r = solver.Solve(home, kHome);
  EXPECT_TRUE(r.success);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_LT(r.pos_error, 1e-9);
  // FK through the solver equals the episode's site pose (same base, same joints).
  const int site = mj_name2id(model_.get(), mjOBJ_SITE, "robot_0/gripper/grasp_site");
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(home(c, 3), data_->site_xpos[3 * site + c], 1e-12);
}

TEST_F(IkTest, ReachesRandomReachablePosesFromHome) {
  for (int restarts : {0, 8}) {
    IkOptions options;
    options.restarts = restarts;
    IkSolver solver = MakeSolver(options);
    const auto configs = RandomConfigs(solver, 300, 20240611);
    int ok = 0, total_iterations = 0;
    double max_pos = 0, max_rot = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& q : configs) {
      const Mat4 target = solver.Forward(q);
      const IkResult r = solver.Solve(target, kHome);
      total_iterations += r.iterations;
      ASSERT_EQ(r.q.size(), 7u);
      for (int i = 0; i < 7; ++i) {  // limits always respected
        EXPECT_GE(r.q[i], solver.lower()[i]);
        EXPECT_LE(r.q[i], solver.upper()[i]);
      }
      if (r.success) {
        ++ok;
        EXPECT_LT(r.pos_error, 1e-3);
        EXPECT_LT(r.rot_error, 1e-3);
        max_pos = std::max(max_pos, r.pos_error);
        max_rot = std::max(max_rot, r.rot_error);
        // The reported q really reaches the target.
        const Mat4 reached = solver.Forward(r.q);
        EXPECT_LT(TranslationDistance(reached, target), 1e-3);
      }
    }
    const double us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() /
        configs.size();
    const double rate = static_cast<double>(ok) / configs.size();
    std::printf(
        "[ik] restarts=%d: success %d/%zu (%.1f%%), mean %.1f iterations, %.1f us/solve, "
        "max residual %.2e m / %.2e rad\n",
        restarts, ok, configs.size(), 100 * rate,
        static_cast<double>(total_iterations) / configs.size(), us, max_pos, max_rot);
    if (restarts == 0) {
      EXPECT_GE(rate, 0.80);
    } else {
      EXPECT_GE(rate, 0.95);
    }
  }
}

TEST_F(IkTest, NearbyTargetsTrackInFewIterations) {
  // The planner's per-step use: targets a few cm from the current pose, seeded there.
  IkSolver solver = MakeSolver();
  const Mat4 home = solver.Forward(kHome);
  int ok = 0;
  for (int k = 0; k < 50; ++k) {
    Mat4 target = home;
    target(0, 3) += 0.002 * k;
    target(2, 3) -= 0.003 * k;
    const IkResult r = solver.Solve(target, kHome);
    ok += r.success;
    EXPECT_LT(r.iterations, 50) << k;
  }
  EXPECT_EQ(ok, 50);
}

TEST_F(IkTest, ReportsFailureForUnreachablePose) {
  IkSolver solver = MakeSolver();
  Mat4 far = solver.Forward(kHome);
  far(0, 3) += 2.0;  // 2 m beyond the arm's ~0.9 m reach
  const IkResult r = solver.Solve(far, kHome);
  EXPECT_FALSE(r.success);
  EXPECT_GT(r.pos_error, 0.5);
  for (int i = 0; i < 7; ++i) {
    EXPECT_GE(r.q[i], solver.lower()[i]);
    EXPECT_LE(r.q[i], solver.upper()[i]);
  }
  EXPECT_EQ(r.attempts, 9);  // the seed + 8 restarts, all failed
  // The iteration cap holds per attempt.
  IkOptions few;
  few.max_iterations = 20;
  few.restarts = 0;
  IkSolver quick = MakeSolver(few);
  const IkResult r2 = quick.Solve(far, kHome);
  EXPECT_FALSE(r2.success);
  EXPECT_EQ(r2.attempts, 1);
  EXPECT_LE(r2.iterations, 20);
}

TEST_F(IkTest, SeedOutsideLimitsIsClampedAndLimitedJointsStayInside) {
  IkSolver solver = MakeSolver();
  std::vector<double> seed = kHome;
  seed[3] = 0.5;  // joint 4's range is [-3.077, -0.1169]
  const Mat4 target = solver.Forward(kHome);
  const IkResult r = solver.Solve(target, seed);
  EXPECT_TRUE(r.success);
  EXPECT_LE(r.q[3], solver.upper()[3]);
}

TEST_F(IkTest, DeterministicAndLeavesEpisodeDataAlone) {
  IkOptions options;
  options.restarts = 3;
  IkSolver a = MakeSolver(options);
  IkSolver b = MakeSolver(options);
  const std::vector<double> before(data_->qpos, data_->qpos + model_->nq);
  const auto configs = RandomConfigs(a, 20, 7);
  for (const auto& q : configs) {
    const Mat4 target = a.Forward(q);
    const IkResult ra = a.Solve(target, kHome);
    const IkResult rb = b.Solve(target, kHome);
    const IkResult ra2 = a.Solve(target, kHome);
    EXPECT_EQ(ra.q, rb.q);
    EXPECT_EQ(ra.q, ra2.q);
    EXPECT_EQ(ra.iterations, rb.iterations);
  }
  const std::vector<double> after(data_->qpos, data_->qpos + model_->nq);
  EXPECT_EQ(before, after);
}

TEST_F(IkTest, RejectsBadArguments) {
  const auto joints = ArmJoints();
  EXPECT_THROW(IkSolver(model_.get(), "no_site", joints), Error);
  const std::vector<std::string> bad = {"robot_0/fr3_joint1", "nope"};
  EXPECT_THROW(IkSolver(model_.get(), "robot_0/gripper/grasp_site", bad), Error);
  IkSolver solver = MakeSolver();
  const std::vector<double> short_seed = {0, 0};
  EXPECT_THROW(solver.Solve(Mat4{}, short_seed), std::logic_error);  // a bug check
}

}  // namespace
}  // namespace mlspaces::robots
