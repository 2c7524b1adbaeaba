#include "mlspaces/core/transform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace mlspaces {
namespace {

void ExpectNear(const Mat4& a, const Mat4& b, double tol = 1e-12) {
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(a.m[i], b.m[i], tol) << "element " << i;
}

TEST(TransformTest, DefaultIsIdentityAndRowMajor) {
  Mat4 m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) EXPECT_EQ(m(r, c), r == c ? 1.0 : 0.0);
  }
  m(0, 3) = 5;
  EXPECT_EQ(m.m[3], 5);
}

TEST(TransformTest, MultiplyComposes) {
  Mat4 a = PoseToMat4({1, 2, 3}, std::array<double, 9>{0, -1, 0, 1, 0, 0, 0, 0, 1});
  Mat4 b = PoseToMat4({0.5, 0, 0}, std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1});
  Mat4 ab = a * b;
  // Rotating (0.5, 0, 0) by +90 deg about z gives (0, 0.5, 0).
  EXPECT_EQ(ab(0, 3), 1);
  EXPECT_EQ(ab(1, 3), 2.5);
  EXPECT_EQ(ab(2, 3), 3);
  ExpectNear(a * Mat4{}, a, 0);
}

TEST(TransformTest, QuaternionMatchesMujocoOrder) {
  // (w, x, y, z) = (cos 45, 0, 0, sin 45): +90 deg about z.
  const double h = std::sqrt(0.5);
  Mat4 q = PoseToMat4({1, 2, 3}, std::array<double, 4>{h, 0, 0, h});
  ExpectNear(q, PoseToMat4({1, 2, 3}, std::array<double, 9>{0, -1, 0, 1, 0, 0, 0, 0, 1}));
  ExpectNear(q, [] {
    Mat4 r = RotZ(std::numbers::pi / 2);
    r(0, 3) = 1;
    r(1, 3) = 2;
    r(2, 3) = 3;
    return r;
  }());
}

TEST(TransformTest, InverseRigid) {
  const double h = std::sqrt(0.5);
  Mat4 t = PoseToMat4({0.3, -1, 2}, std::array<double, 4>{h, h, 0, 0});
  ExpectNear(t * InverseRigid(t), Mat4{});
  ExpectNear(InverseRigid(t) * t, Mat4{});
  ExpectNear(InverseRigid(InverseRigid(t)), t);
}

TEST(TransformTest, RotZ) {
  Mat4 r = RotZ(std::numbers::pi / 6);
  EXPECT_NEAR(r(0, 0), std::sqrt(3) / 2, 1e-15);
  EXPECT_NEAR(r(1, 0), 0.5, 1e-15);
  EXPECT_NEAR(r(0, 1), -0.5, 1e-15);
  EXPECT_EQ(r(2, 2), 1);
  // RotZ(pi) is only approximately diag(-1, -1, 1): sin(pi) is not 0 in double.
  Mat4 flip = RotZ(std::numbers::pi);
  EXPECT_EQ(flip(0, 0), -1);
  EXPECT_NE(flip(1, 0), 0);
  EXPECT_NEAR(flip(1, 0), 0, 1e-15);
}

}  // namespace
}  // namespace mlspaces
