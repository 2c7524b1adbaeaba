// SE(3) helpers for the pick planner: unit quaternions, rotation logs, pose interpolation
// (linear position, slerp orientation) and timed waypoints between two TCP poses.
//
// Quaternions are (w, x, y, z), MuJoCo's order; poses are mlspaces::Mat4 (row-major).
#pragma once

#include <array>
#include <vector>

#include "mlspaces/core/transform.h"

namespace mlspaces::datagen {

using Vec3 = std::array<double, 3>;
/// Unit quaternion (w, x, y, z).
using Quat = std::array<double, 4>;

/// Rotation part of a pose as a unit quaternion with w >= 0 (Shepperd's method).
Quat QuatFromMat4(const Mat4& pose);
/// Position part of a pose.
Vec3 Translation(const Mat4& pose);
/// Pose from a position and a quaternion (normalised here).
Mat4 MakePose(const Vec3& pos, const Quat& quat);

Quat QuatMul(const Quat& a, const Quat& b);
Quat QuatConjugate(const Quat& q);
Quat QuatNormalized(const Quat& q);
/// Spherical linear interpolation along the shorter arc; t in [0, 1]. Falls back to a
/// normalised lerp when the quaternions are nearly equal. Always returns a unit quaternion.
Quat Slerp(const Quat& a, Quat b, double t);

/// Rotation vector (axis * angle, angle in [0, pi]) of a 3x3 rotation given as the rotation
/// block of `r`.
Vec3 RotationLog(const Mat4& r);
/// Rotation vector (axis * angle) of a row-major 3x3 rotation, angle in [0, pi].
Vec3 RotationLog3(const std::array<double, 9>& r);
/// Geodesic angle (rad, [0, pi]) between the rotations of two poses.
double RotationAngle(const Mat4& a, const Mat4& b);
/// Euclidean distance between the positions of two poses.
double TranslationDistance(const Mat4& a, const Mat4& b);

/// Pose at fraction s of the way from `a` to `b`: position a + s (b - a) (a straight line),
/// orientation Slerp(q_a, q_b, s). s is clamped to [0, 1]; s = 0 / 1 return a / b exactly.
Mat4 InterpolatePose(const Mat4& a, const Mat4& b, double s);

struct SegmentTiming {
  /// Linear TCP speed, m/s (the original's segment speeds: 0.20 to pregrasp, 0.08 after).
  double speed = 0.08;
  /// Angular speed bound, rad/s; <= 0 ignores rotation as the original does (where a pure
  /// re-orientation then gets duration 0, spec 15.10).
  double angular_speed = 1.0;
};

/// Duration (s) of a segment: max(|p_b - p_a| / speed, angle(a, b) / angular_speed).
/// @throws std::invalid_argument for speed <= 0.
double SegmentDuration(const Mat4& a, const Mat4& b, const SegmentTiming& timing);

/// Waypoints from `a` to `b` sampled at `rate_hz`: pose k = InterpolatePose(a, b,
/// min(1, k / (rate_hz * duration))) for k = 0 .. ceil(rate_hz * duration), so the first
/// is `a`, the last is exactly `b` and consecutive ones are at most speed / rate_hz apart in
/// position. A zero-duration segment gives {a, b}. @throws std::invalid_argument for
/// rate_hz <= 0 or speed <= 0.
std::vector<Mat4> Waypoints(const Mat4& a, const Mat4& b, const SegmentTiming& timing,
                            double rate_hz);

}  // namespace mlspaces::datagen
