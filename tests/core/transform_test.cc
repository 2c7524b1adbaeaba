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
  Mat4 a = ToMat4({1, 2, 3}, Rot3{0, -1, 0, 1, 0, 0, 0, 0, 1});
  Mat4 b = ToMat4({0.5, 0, 0}, Rot3{1, 0, 0, 0, 1, 0, 0, 0, 1});
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
  Mat4 q = ToMat4(Pose{{1, 2, 3}, {h, 0, 0, h}});
  ExpectNear(q, ToMat4({1, 2, 3}, Rot3{0, -1, 0, 1, 0, 0, 0, 0, 1}));
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
  Mat4 t = ToMat4(Pose{{0.3, -1, 2}, {h, h, 0, 0}});
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

TEST(TransformTest, AxisAngleAndTranslate) {
  // About z it is RotZ; about any unit axis the axis is fixed and the angle is kept.
  const Mat4 z = AxisAngle({0, 0, 1}, 0.7), rz = RotZ(0.7);
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(z.m[i], rz.m[i], 1e-15) << i;
  const double k = 1 / std::sqrt(3.0);
  const Mat4 r = AxisAngle({k, k, k}, 2 * std::numbers::pi / 3);  // cycles x -> y -> z
  EXPECT_NEAR(r(1, 0), 1, 1e-12);
  EXPECT_NEAR(r(2, 1), 1, 1e-12);
  EXPECT_NEAR(r(0, 2), 1, 1e-12);
  const Mat4 t = Translate({1, 2, 3}) * r;
  EXPECT_EQ(Translation(t), (Vec3{1, 2, 3}));
  EXPECT_EQ(Rotation(t), Rotation(r));
}

TEST(TransformTest, PoseMatrixAndArray7RoundTrips) {
  const Pose pose{{0.5, -0.25, 1.5}, QuatNormalized({0.3, -0.2, 0.9, 0.1})};
  const Mat4 t = ToMat4(pose);
  EXPECT_EQ(Translation(t), pose.pos);
  const Pose back = ToPose(t);
  EXPECT_EQ(back.pos, pose.pos);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(back.quat[i], pose.quat[i], 1e-14) << i;
  // w < 0 comes back as the same rotation with w >= 0.
  const Pose flipped{{0, 0, 0}, {-pose.quat[0], -pose.quat[1], -pose.quat[2], -pose.quat[3]}};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(ToPose(ToMat4(flipped)).quat[i], pose.quat[i], 1e-14);
  // [x, y, z, qw, qx, qy, qz], taken as given (not normalised).
  const Array7 a{1, 2, 3, 2, 0, 0, 0};
  EXPECT_EQ(FromArray7(a), (Pose{{1, 2, 3}, {2, 0, 0, 0}}));
  EXPECT_EQ(ToArray7(FromArray7(a)), a);
  EXPECT_EQ(ToArray7(pose)[3], pose.quat[0]);
  EXPECT_EQ(ToArray7(pose)[2], 1.5);
  // The xmat form and the quaternion form give the same matrix.
  ExpectNear(ToMat4(pose.pos, QuatToRotation(pose.quat)), t, 0);
  ExpectNear(ToMat4(pose.pos, Rotation(t)), t, 0);
}

TEST(TransformTest, QuaternionAlgebra) {
  const double h = std::sqrt(0.5);
  const Quat z90{h, 0, 0, h}, x90{h, h, 0, 0};
  // q * conj(q) is the identity; multiplication composes like the matrices.
  const Quat id = QuatMul(z90, QuatConjugate(z90));
  EXPECT_NEAR(id[0], 1, 1e-15);
  for (int i = 1; i < 4; ++i) EXPECT_NEAR(id[i], 0, 1e-15);
  ExpectNear(ToMat4(Pose{{}, QuatMul(z90, x90)}), ToMat4(Pose{{}, z90}) * ToMat4(Pose{{}, x90}));
  EXPECT_EQ(QuatNormalized({0, 0, 0, 0}), (Quat{1, 0, 0, 0}));
  EXPECT_EQ(QuatNormalized({0, 0, 0, 2}), (Quat{0, 0, 0, 1}));
  // Rotation matrix round trip through every branch of Shepperd's method.
  for (const Quat& q : {Quat{1, 0, 0, 0}, Quat{0, 1, 0, 0}, Quat{0, 0, 1, 0}, Quat{0, 0, 0, 1},
                        QuatNormalized({0.1, 0.7, -0.2, 0.3})}) {
    const Quat back = QuatFromRotation(QuatToRotation(q));
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(back[i], q[i], 1e-14) << i;
  }
  // Slerp halfway between identity and z90 is z45.
  const Quat mid = Slerp({1, 0, 0, 0}, z90, 0.5);
  EXPECT_NEAR(mid[0], std::cos(std::numbers::pi / 8), 1e-14);
  EXPECT_NEAR(mid[3], std::sin(std::numbers::pi / 8), 1e-14);
}

}  // namespace
}  // namespace mlspaces
