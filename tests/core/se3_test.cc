// SE(3) helpers (src/core/se3.cc): quaternion round trips, rotation logs, pose
// interpolation (linear position + slerp) and timed waypoints.
#include "mlspaces/core/se3.h"
#include "mlspaces/core/error.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

namespace mlspaces {
namespace {

constexpr double kPi = 3.14159265358979323846;

Quat AxisAngle(Vec3 axis, double angle) {
  const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  const double s = std::sin(angle / 2) / n;
  return {std::cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s};
}

// The matrix of a position and a (normalised) quaternion.
Mat4 MakePose(const Vec3& pos, const Quat& quat) { return ToMat4(Pose{pos, QuatNormalized(quat)}); }

double MaxDiff(const Mat4& a, const Mat4& b) {
  double e = 0;
  for (int i = 0; i < 16; ++i) e = std::max(e, std::abs(a.m[i] - b.m[i]));
  return e;
}

TEST(Se3Test, QuaternionRoundTripAllBranches) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0, 1);
  for (int k = 0; k < 200; ++k) {
    Quat q = QuatNormalized({n(rng), n(rng), n(rng), n(rng)});
    if (q[0] < 0) q = {-q[0], -q[1], -q[2], -q[3]};
    const Quat back = QuatFromMat4(MakePose({0, 0, 0}, q));
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(back[i], q[i], 1e-12);
  }
  // 180-degree rotations (trace -1) about each axis.
  for (Vec3 axis : {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}}) {
    const Mat4 p = MakePose({0, 0, 0}, AxisAngle(axis, kPi));
    const Vec3 w = RotationLog(p);
    EXPECT_NEAR(std::hypot(w[0], w[1], w[2]), kPi, 1e-9);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(std::abs(w[c]), kPi * axis[c], 1e-9);
  }
}

TEST(Se3Test, RotationLogAndAngle) {
  const Mat4 a = MakePose({1, 2, 3}, AxisAngle({0, 0, 1}, 0.3));
  const Mat4 b = MakePose({1, 2, 4}, AxisAngle({0, 0, 1}, 1.0));
  EXPECT_NEAR(RotationAngle(a, b), 0.7, 1e-12);
  EXPECT_NEAR(TranslationDistance(a, b), 1.0, 1e-15);
  const Vec3 w = RotationLog(MakePose({0, 0, 0}, AxisAngle({1, 1, 0}, 0.5)));
  EXPECT_NEAR(w[0], 0.5 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(w[1], 0.5 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(w[2], 0.0, 1e-12);
  const Vec3 tiny = RotationLog(MakePose({0, 0, 0}, AxisAngle({0, 1, 0}, 1e-9)));
  EXPECT_NEAR(tiny[1], 1e-9, 1e-15);
}

TEST(Se3Test, SlerpShorterArcAndMidpoint) {
  const Quat a = AxisAngle({0, 0, 1}, 0.0);
  const Quat b = AxisAngle({0, 0, 1}, 1.2);
  const Quat mid = Slerp(a, b, 0.5);
  const Quat expect = AxisAngle({0, 0, 1}, 0.6);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(mid[i], expect[i], 1e-12);
  // -b is the same rotation: the result must not take the long way round.
  const Quat neg = {-b[0], -b[1], -b[2], -b[3]};
  const Quat mid2 = Slerp(a, neg, 0.5);
  EXPECT_NEAR(RotationAngle(MakePose({0, 0, 0}, mid2), MakePose({0, 0, 0}, expect)), 0, 1e-9);
}

TEST(Se3Test, InterpolatePoseEndpointsAndStraightLine) {
  const Mat4 a = MakePose({0.3, 0.0, 0.5}, AxisAngle({1, 0, 0}, kPi));
  const Mat4 b = MakePose({0.4, 0.1, 0.1}, AxisAngle({1, 1, 0}, 2.0));
  EXPECT_EQ(MaxDiff(InterpolatePose(a, b, 0.0), a), 0.0);
  EXPECT_EQ(MaxDiff(InterpolatePose(a, b, 1.0), b), 0.0);
  EXPECT_EQ(MaxDiff(InterpolatePose(a, b, -3.0), a), 0.0);  // clamped
  EXPECT_EQ(MaxDiff(InterpolatePose(a, b, 7.0), b), 0.0);
  const Mat4 m = InterpolatePose(a, b, 0.25);
  EXPECT_NEAR(m(0, 3), 0.325, 1e-15);
  EXPECT_NEAR(m(1, 3), 0.025, 1e-15);
  EXPECT_NEAR(m(2, 3), 0.4, 1e-15);
  const double total = RotationAngle(a, b);
  EXPECT_NEAR(RotationAngle(a, m), 0.25 * total, 1e-9);
  EXPECT_NEAR(RotationAngle(m, b), 0.75 * total, 1e-9);
}

TEST(Se3Test, WaypointsAtSpeedAndRate) {
  const Mat4 a = MakePose({0.3, 0.0, 0.5}, AxisAngle({1, 0, 0}, kPi));
  const Mat4 b = MakePose({0.4, 0.0, 0.1}, AxisAngle({1, 0, 0}, kPi - 0.4));
  SegmentTiming timing;
  timing.speed = 0.2;
  timing.angular_speed = 1.0;
  const double dist = TranslationDistance(a, b);
  EXPECT_NEAR(SegmentDuration(a, b, timing), dist / 0.2, 1e-12);  // translation dominates
  const double rate = 15.0;
  const auto w = Waypoints(a, b, timing, rate);
  ASSERT_EQ(w.size(), static_cast<size_t>(std::ceil(rate * dist / 0.2)) + 1);
  EXPECT_EQ(MaxDiff(w.front(), a), 0.0);
  EXPECT_EQ(MaxDiff(w.back(), b), 0.0);
  double prev_d = -1, prev_r = -1;
  for (const Mat4& p : w) {
    const double d = TranslationDistance(a, p), r = RotationAngle(a, p);
    EXPECT_GT(d, prev_d);  // strictly monotonic progress
    EXPECT_GE(r, prev_r - 1e-12);
    prev_d = d;
    prev_r = r;
    const Quat q = QuatFromMat4(p);
    EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
    double det = 0;  // rotation block stays orthonormal
    det = p(0, 0) * (p(1, 1) * p(2, 2) - p(1, 2) * p(2, 1)) -
          p(0, 1) * (p(1, 0) * p(2, 2) - p(1, 2) * p(2, 0)) +
          p(0, 2) * (p(1, 0) * p(2, 1) - p(1, 1) * p(2, 0));
    EXPECT_NEAR(det, 1.0, 1e-12);
  }
  for (size_t k = 1; k < w.size(); ++k) {
    EXPECT_LE(TranslationDistance(w[k - 1], w[k]), 0.2 / rate + 1e-12);
  }
}

TEST(Se3Test, PureRotationGetsAngularDurationAndZeroSegmentTwoPoints) {
  const Mat4 a = MakePose({0.3, 0.0, 0.5}, AxisAngle({0, 0, 1}, 0.0));
  const Mat4 b = MakePose({0.3, 0.0, 0.5}, AxisAngle({0, 0, 1}, 0.5));
  SegmentTiming timing;
  timing.speed = 0.08;
  timing.angular_speed = 0.5;
  EXPECT_NEAR(SegmentDuration(a, b, timing), 1.0, 1e-12);
  EXPECT_EQ(Waypoints(a, b, timing, 10).size(), 11u);
  timing.angular_speed = 0;  // the original: rotation ignored -> duration 0
  EXPECT_EQ(SegmentDuration(a, b, timing), 0.0);
  const auto w = Waypoints(a, b, timing, 10);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(MaxDiff(w[1], b), 0.0);
  EXPECT_THROW(Waypoints(a, b, timing, 0), Error);
  timing.speed = 0;
  EXPECT_THROW(SegmentDuration(a, b, timing), Error);
}

}  // namespace
}  // namespace mlspaces
