// MeshBvh (src/graspgen/bvh.cc): ray casts agree with brute force; box overlap cases.
#include <cmath>

#include <gtest/gtest.h>

#include "graspgen/assets.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/graspgen/mesh.h"

namespace mlspaces::graspgen {
namespace {

// A soup of 400 random triangles in a 0.2 m cube plus the L-bracket: overlapping, touching and
// thin triangles, so the tree has depth and awkward splits.
TriMesh RandomSoup(uint64_t seed) {
  TriMesh m;
  Rng rng(seed);
  for (int t = 0; t < 400; ++t) {
    const Vec3 c{rng.Uniform(-0.1, 0.1), rng.Uniform(-0.1, 0.1), rng.Uniform(-0.1, 0.1)};
    for (int k = 0; k < 3; ++k) {
      m.vertices.push_back({c[0] + rng.Uniform(-0.03, 0.03), c[1] + rng.Uniform(-0.03, 0.03),
                            c[2] + rng.Uniform(-0.03, 0.03)});
    }
    const auto b = static_cast<int32_t>(3 * t);
    m.faces.push_back({b, b + 1, b + 2});
  }
  return m;
}

Vec3 RandomUnit(Rng& rng) {
  for (;;) {
    const Vec3 v{rng.Uniform(-1, 1), rng.Uniform(-1, 1), rng.Uniform(-1, 1)};
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 0.1 && n <= 1) return {v[0] / n, v[1] / n, v[2] / n};
  }
}

TEST(GraspgenBvhTest, RaycastAgreesWithBruteForceOnRandomRays) {
  const TriMesh soup = RandomSoup(1);
  const MeshBvh bvh(soup);
  EXPECT_GT(bvh.NodeCount(), 100u);
  Rng rng(2);
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 o{rng.Uniform(-0.2, 0.2), rng.Uniform(-0.2, 0.2), rng.Uniform(-0.2, 0.2)};
    Vec3 d = RandomUnit(rng);
    if (i % 10 == 0) d = {0, 0, i % 20 == 0 ? 1.0 : -1.0};  // axis-parallel rays too
    const double tmax = rng.Uniform(0.01, 0.5);
    const auto a = bvh.Raycast(o, d, tmax);
    const auto b = RaycastBruteForce(soup, o, d, tmax);
    ASSERT_EQ(a.has_value(), b.has_value()) << i;
    if (!a) continue;
    ++hits;
    EXPECT_EQ(a->t, b->t) << i;
    EXPECT_EQ(a->face, b->face) << i;
    EXPECT_LE(a->t, tmax);
  }
  EXPECT_GT(hits, 300);  // the test exercises hits, not only misses
}

TEST(GraspgenBvhTest, RaycastOnABoxMeshHitsTheNearFace) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(AssetCollisionMesh(testing::WriteBoxAsset(dir.path())));
  const auto hit = bvh.Raycast({0.01, 0.005, 0.5}, {0, 0, -1}, 1.0);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t, 0.46, 1e-12);
  EXPECT_NEAR(FaceNormal(bvh.mesh(), hit->face)[2], 1, 1e-12);
  EXPECT_FALSE(bvh.Raycast({0.01, 0.005, 0.5}, {0, 0, -1}, 0.45));  // too short
  EXPECT_FALSE(bvh.Raycast({0.01, 0.005, 0.5}, {0, 0, 1}, 1.0));    // pointing away
  // From inside, the exit face is hit (both sides count).
  const auto out = bvh.Raycast({0, 0, 0}, {1, 0, 0}, 1.0);
  ASSERT_TRUE(out);
  EXPECT_NEAR(out->t, 0.02, 1e-12);
}

TEST(GraspgenBvhTest, OrientedBoxOverlap) {
  mlspaces::testing::TempDir dir;
  const MeshBvh bvh(AssetCollisionMesh(testing::WriteBoxAsset(dir.path())));  // +-.02 .025 .04
  OrientedBox b;
  b.half = {0.01, 0.01, 0.01};
  b.center = {0.029, 0, 0};  // reaches 1 mm into the +x face
  EXPECT_TRUE(bvh.Overlaps(b));
  b.center = {0.031, 0, 0};  // 1 mm away
  EXPECT_FALSE(bvh.Overlaps(b));
  b.center = {0, 0, 0};  // inside, touching no triangle (documented)
  EXPECT_FALSE(bvh.Overlaps(b));
  b.half = {0.05, 0.001, 0.001};  // a needle through the box
  EXPECT_TRUE(bvh.Overlaps(b));
  // Near the +x+y edge along the diagonal: axis-aligned, its corner faces the edge and reaches
  // it at distance 0.01 * sqrt(2); turned 45 deg about z, its face does, at 0.01.
  const double c = std::sqrt(0.5);
  b.half = {0.01, 0.01, 0.01};
  for (bool turned : {false, true}) {
    b.rot = turned ? Rot3{c, -c, 0, c, c, 0, 0, 0, 1} : Rot3{1, 0, 0, 0, 1, 0, 0, 0, 1};
    const double reach = turned ? 0.01 : 0.01 * std::sqrt(2.0);
    for (double gap : {-0.0005, 0.0005}) {
      const double d = reach + gap;
      b.center = {0.02 + d * c, 0.025 + d * c, 0};
      EXPECT_EQ(bvh.Overlaps(b), gap < 0) << turned << " " << gap;
    }
  }
}

}  // namespace
}  // namespace mlspaces::graspgen
