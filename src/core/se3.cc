#include "mlspaces/core/se3.h"

#include <algorithm>
#include <cmath>

#include "mlspaces/core/error.h"

namespace mlspaces {

Vec3 RotationLog3(const Rot3& r) {
  // Via the quaternion: robust at small angles and at pi.
  const Quat q = QuatFromRotation(r);  // w >= 0 -> angle in [0, pi]
  const double vn = std::sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (vn < 1e-12) return {2 * q[1], 2 * q[2], 2 * q[3]};
  const double angle = 2.0 * std::atan2(vn, q[0]);
  const double k = angle / vn;
  return {k * q[1], k * q[2], k * q[3]};
}

Vec3 RotationLog(const Mat4& r) { return RotationLog3(Rotation(r)); }

double RotationAngle(const Mat4& a, const Mat4& b) {
  // angle of a^T b
  Rot3 rel{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += a(k, i) * b(k, j);
      rel[3 * i + j] = s;
    }
  }
  const Vec3 w = RotationLog3(rel);
  return std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
}

double TranslationDistance(const Mat4& a, const Mat4& b) {
  const double dx = a(0, 3) - b(0, 3), dy = a(1, 3) - b(1, 3), dz = a(2, 3) - b(2, 3);
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

Mat4 InterpolatePose(const Mat4& a, const Mat4& b, double s) {
  s = std::clamp(s, 0.0, 1.0);
  if (s == 0.0) return a;
  if (s == 1.0) return b;
  const Vec3 pa = Translation(a), pb = Translation(b);
  const Vec3 p = {pa[0] + s * (pb[0] - pa[0]), pa[1] + s * (pb[1] - pa[1]),
                  pa[2] + s * (pb[2] - pa[2])};
  return ToMat4(Pose{p, QuatNormalized(Slerp(QuatFromMat4(a), QuatFromMat4(b), s))});
}

double SegmentDuration(const Mat4& a, const Mat4& b, const SegmentTiming& timing) {
  if (!(timing.speed > 0)) {
    throw Error("segment speed must be > 0, got " + std::to_string(timing.speed), "", "speed");
  }
  double duration = TranslationDistance(a, b) / timing.speed;
  if (timing.angular_speed > 0) {
    duration = std::max(duration, RotationAngle(a, b) / timing.angular_speed);
  }
  return duration;
}

std::vector<Mat4> Waypoints(const Mat4& a, const Mat4& b, const SegmentTiming& timing,
                            double rate_hz) {
  if (!(rate_hz > 0)) {
    throw Error("waypoint rate must be > 0 Hz, got " + std::to_string(rate_hz), "", "rate_hz");
  }
  const double duration = SegmentDuration(a, b, timing);
  const double steps = rate_hz * duration;
  const size_t n = std::max<size_t>(1, static_cast<size_t>(std::ceil(steps - 1e-9)));
  std::vector<Mat4> out;
  out.reserve(n + 1);
  for (size_t k = 0; k <= n; ++k) {
    const double s = steps > 0 ? std::min(1.0, static_cast<double>(k) / steps) : 1.0;
    out.push_back(k == 0 ? a : (k == n ? b : InterpolatePose(a, b, s)));
  }
  return out;
}

}  // namespace mlspaces
