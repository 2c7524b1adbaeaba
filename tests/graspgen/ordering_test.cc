// Candidate test order (src/graspgen/ordering.cc): clusters, depth weighting, round-robin.
#include "mlspaces/graspgen/ordering.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "graspgen/assets.h"

namespace mlspaces::graspgen {
namespace {

GraspCandidate At(double x, double depth) {
  GraspCandidate c;
  c.tcp(0, 3) = x;
  c.depth = depth;
  c.quality = 1;
  return c;
}

TEST(GraspgenOrderingTest, TwoSeparateGroupsAlternate) {
  std::vector<GraspCandidate> c;
  c.reserve(20);
  for (int i = 0; i < 20; ++i) c.push_back(At(i < 10 ? 0.001 * i : 1 + 0.001 * i, 0.75));
  OrderParams p;
  p.clusters = 2;
  const std::vector<int> label = ClusterCandidates(c, 2, 100, 3);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(label[i], i < 10 ? 0 : 1) << i;
  const std::vector<size_t> order = OrderCandidates(c, p, 3);
  ASSERT_EQ(order.size(), 20u);
  for (size_t i = 0; i < order.size(); ++i) EXPECT_EQ(order[i] < 10, i % 2 == 0) << i;
}

TEST(GraspgenOrderingTest, DepthRangeAndDepthPreference) {
  std::vector<GraspCandidate> c;
  c.reserve(400);
  for (int i = 0; i < 400; ++i) c.push_back(At(0.0001 * i, (i % 20) / 19.0));
  OrderParams p;
  p.clusters = 1;
  p.min_depth = 0.1;
  const std::vector<size_t> order = OrderCandidates(c, p, 5);
  EXPECT_EQ(order.size(), 360u);  // depths 0 and 1/19 left out
  EXPECT_EQ(std::set<size_t>(order.begin(), order.end()).size(), order.size());
  for (size_t i : order) EXPECT_GE(c[i].depth, 0.1);
  // The first tenth sits much nearer the preferred depth 0.75 than the whole set.
  double head = 0, all = 0;
  for (size_t i = 0; i < order.size(); ++i) {
    const double d = std::abs(c[order[i]].depth - 0.75);
    all += d;
    if (i < 36) head += d;
  }
  EXPECT_LT(head / 36, 0.25 * all / order.size());
}

TEST(GraspgenOrderingTest, BoxCandidatesAreCoveredEarlyAndSeeded) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(AssetCollisionMesh(testing::WriteBoxAsset(dir.path())));
  CandidateParams cp;
  cp.surface_density = 1e-4;
  const CandidateSet set = GenerateCandidates(bvh, FrankaDroidGripperProxy(), cp, 2);
  const std::vector<size_t> order = OrderCandidates(set.candidates, {}, 8);
  ASSERT_EQ(order.size(), set.candidates.size());
  EXPECT_EQ(std::set<size_t>(order.begin(), order.end()).size(), order.size());
  // The first 40 (one per cluster) approach from all six faces.
  std::set<int> faces;
  for (size_t i = 0; i < 40; ++i) {
    const Vec3& n = set.candidates[order[i]].normal;
    for (int k = 0; k < 3; ++k) {
      if (std::abs(n[k]) > 0.5) faces.insert(2 * k + (n[k] > 0));
    }
  }
  EXPECT_EQ(faces.size(), 6u);
  EXPECT_EQ(OrderCandidates(set.candidates, {}, 8), order);
  EXPECT_NE(OrderCandidates(set.candidates, {}, 9), order);
}

}  // namespace
}  // namespace mlspaces::graspgen
