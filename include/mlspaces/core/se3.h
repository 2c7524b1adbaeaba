// SE(3) helpers for motion planning: rotation logs, distances between poses, pose
// interpolation (linear position, slerp orientation) and timed waypoints between two poses.
// Poses here are Mat4 (core/transform.h, which holds the quaternion helpers).
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <vector>

#include "mlspaces/core/transform.h"

namespace mlspaces {

/// Rotation vector (axis * angle, angle in [0, pi]) of the rotation block of `r`.
MLSPACES_API Vec3 RotationLog(const Mat4& r);
/// Rotation vector (axis * angle) of a row-major 3x3 rotation, angle in [0, pi].
MLSPACES_API Vec3 RotationLog3(const Rot3& r);
/// Geodesic angle (rad, [0, pi]) between the rotations of two poses.
MLSPACES_API double RotationAngle(const Mat4& a, const Mat4& b);
/// Euclidean distance between the positions of two poses.
MLSPACES_API double TranslationDistance(const Mat4& a, const Mat4& b);

/// Pose at fraction s of the way from `a` to `b`: position a + s (b - a) (a straight line),
/// orientation Slerp(q_a, q_b, s). s is clamped to [0, 1]; s = 0 / 1 return a / b exactly.
MLSPACES_API Mat4 InterpolatePose(const Mat4& a, const Mat4& b, double s);

struct MLSPACES_API SegmentTiming {
  /// Linear TCP speed, m/s.
  double speed = 0.08;
  /// Angular speed bound, rad/s; <= 0 ignores rotation (a pure re-orientation then gets
  /// duration 0, spec 15.10).
  double angular_speed = 1.0;
};

/// Duration (s) of a segment: max(|p_b - p_a| / speed, angle(a, b) / angular_speed).
/// @throws Error (field "speed") for speed <= 0.
MLSPACES_API double SegmentDuration(const Mat4& a, const Mat4& b, const SegmentTiming& timing);

/// Waypoints from `a` to `b` sampled at `rate_hz`: pose k = InterpolatePose(a, b,
/// min(1, k / (rate_hz * duration))) for k = 0 .. ceil(rate_hz * duration), so the first
/// is `a`, the last is exactly `b` and consecutive ones are at most speed / rate_hz apart in
/// position. A zero-duration segment gives {a, b}. @throws Error (field "rate_hz" /
/// "speed") for rate_hz <= 0 or speed <= 0.
MLSPACES_API std::vector<Mat4> Waypoints(const Mat4& a, const Mat4& b, const SegmentTiming& timing,
                                         double rate_hz);

}  // namespace mlspaces
