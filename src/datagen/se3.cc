#include "mlspaces/datagen/se3.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mlspaces::datagen {

Quat QuatFromMat4(const Mat4& p) {
  const double m00 = p(0, 0), m11 = p(1, 1), m22 = p(2, 2);
  const double trace = m00 + m11 + m22;
  Quat q;
  if (trace > 0) {
    const double s = 2.0 * std::sqrt(1.0 + trace);
    q = {0.25 * s, (p(2, 1) - p(1, 2)) / s, (p(0, 2) - p(2, 0)) / s, (p(1, 0) - p(0, 1)) / s};
  } else if (m00 > m11 && m00 > m22) {
    const double s = 2.0 * std::sqrt(1.0 + m00 - m11 - m22);
    q = {(p(2, 1) - p(1, 2)) / s, 0.25 * s, (p(0, 1) + p(1, 0)) / s, (p(0, 2) + p(2, 0)) / s};
  } else if (m11 > m22) {
    const double s = 2.0 * std::sqrt(1.0 + m11 - m00 - m22);
    q = {(p(0, 2) - p(2, 0)) / s, (p(0, 1) + p(1, 0)) / s, 0.25 * s, (p(1, 2) + p(2, 1)) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m22 - m00 - m11);
    q = {(p(1, 0) - p(0, 1)) / s, (p(0, 2) + p(2, 0)) / s, (p(1, 2) + p(2, 1)) / s, 0.25 * s};
  }
  if (q[0] < 0) {
    for (double& c : q) c = -c;
  }
  return QuatNormalized(q);
}

Vec3 Translation(const Mat4& pose) { return {pose(0, 3), pose(1, 3), pose(2, 3)}; }

Mat4 MakePose(const Vec3& pos, const Quat& quat) { return PoseToMat4(pos, QuatNormalized(quat)); }

Quat QuatMul(const Quat& a, const Quat& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

Quat QuatConjugate(const Quat& q) { return {q[0], -q[1], -q[2], -q[3]}; }

Quat QuatNormalized(const Quat& q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(n > 0)) return {1, 0, 0, 0};
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

Quat Slerp(const Quat& a, Quat b, double t) {
  double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (dot < 0) {  // shorter arc
    for (double& c : b) c = -c;
    dot = -dot;
  }
  if (dot > 0.9995) {
    Quat q;
    for (int i = 0; i < 4; ++i) q[i] = a[i] + t * (b[i] - a[i]);
    return QuatNormalized(q);
  }
  const double theta = std::acos(std::min(1.0, dot));
  const double s = std::sin(theta);
  const double wa = std::sin((1 - t) * theta) / s, wb = std::sin(t * theta) / s;
  Quat q;
  for (int i = 0; i < 4; ++i) q[i] = wa * a[i] + wb * b[i];
  return QuatNormalized(q);
}

Vec3 RotationLog3(const std::array<double, 9>& r) {
  // Via the quaternion: robust at small angles and at pi.
  Mat4 p;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p(i, j) = r[3 * i + j];
  }
  const Quat q = QuatFromMat4(p);  // w >= 0 -> angle in [0, pi]
  const double vn = std::sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (vn < 1e-12) return {2 * q[1], 2 * q[2], 2 * q[3]};
  const double angle = 2.0 * std::atan2(vn, q[0]);
  const double k = angle / vn;
  return {k * q[1], k * q[2], k * q[3]};
}

Vec3 RotationLog(const Mat4& r) {
  std::array<double, 9> m{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[3 * i + j] = r(i, j);
  }
  return RotationLog3(m);
}

double RotationAngle(const Mat4& a, const Mat4& b) {
  // angle of a^T b
  std::array<double, 9> rel{};
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
  return MakePose(p, Slerp(QuatFromMat4(a), QuatFromMat4(b), s));
}

double SegmentDuration(const Mat4& a, const Mat4& b, const SegmentTiming& timing) {
  if (!(timing.speed > 0)) throw std::invalid_argument("SegmentDuration: speed must be > 0");
  double duration = TranslationDistance(a, b) / timing.speed;
  if (timing.angular_speed > 0) {
    duration = std::max(duration, RotationAngle(a, b) / timing.angular_speed);
  }
  return duration;
}

std::vector<Mat4> Waypoints(const Mat4& a, const Mat4& b, const SegmentTiming& timing,
                            double rate_hz) {
  if (!(rate_hz > 0)) throw std::invalid_argument("Waypoints: rate_hz must be > 0");
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

}  // namespace mlspaces::datagen
