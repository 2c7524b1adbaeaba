// Internal: small quaternion/vector math used by the composer (MuJoCo's conventions).
#pragma once

#include <array>
#include <cmath>

namespace mlspaces::sim::internal {

using Vec3 = std::array<double, 3>;
using Quat = std::array<double, 4>;  // w, x, y, z

inline Quat QuatMul(const Quat& a, const Quat& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

inline Quat QuatNormalize(Quat q) {
  double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (n < 1e-15) return {1, 0, 0, 0};
  for (double& v : q) v /= n;
  return q;
}

inline Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

inline double Norm(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

inline Vec3 Normalized(Vec3 v) {
  double n = Norm(v);
  if (n < 1e-15) return v;
  for (double& x : v) x /= n;
  return v;
}

/// Rotates v by unit quaternion q.
inline Vec3 Rotate(const Quat& q, const Vec3& v) {
  Quat p{0, v[0], v[1], v[2]};
  Quat qc{q[0], -q[1], -q[2], -q[3]};
  Quat r = QuatMul(QuatMul(q, p), qc);
  return {r[1], r[2], r[3]};
}

inline Quat AxisAngle(Vec3 axis, double angle) {
  axis = Normalized(axis);
  double s = std::sin(angle / 2);
  return {std::cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s};
}

/// Rotation matrix with columns x, y, z (orthonormal) to quaternion.
inline Quat FrameToQuat(const Vec3& x, const Vec3& y, const Vec3& z) {
  // m[r][c]: column c is axis c.
  double m00 = x[0], m10 = x[1], m20 = x[2];
  double m01 = y[0], m11 = y[1], m21 = y[2];
  double m02 = z[0], m12 = z[1], m22 = z[2];
  double tr = m00 + m11 + m22;
  Quat q;
  if (tr > 0) {
    double s = std::sqrt(tr + 1.0) * 2;
    q = {0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s};
  } else if (m00 > m11 && m00 > m22) {
    double s = std::sqrt(1.0 + m00 - m11 - m22) * 2;
    q = {(m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s};
  } else if (m11 > m22) {
    double s = std::sqrt(1.0 + m11 - m00 - m22) * 2;
    q = {(m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s};
  } else {
    double s = std::sqrt(1.0 + m22 - m00 - m11) * 2;
    q = {(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s};
  }
  if (q[0] < 0) {
    for (double& v : q) v = -v;
  }
  return QuatNormalize(q);
}

/// MuJoCo's xyaxes: x normalised, y made orthogonal to x, z = x cross y.
inline Quat XYAxesToQuat(Vec3 x, Vec3 y) {
  x = Normalized(x);
  double d = x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
  for (int i = 0; i < 3; ++i) y[i] -= d * x[i];
  y = Normalized(y);
  Vec3 z = Normalized(Cross(x, y));
  return FrameToQuat(x, y, z);
}

/// MuJoCo's zaxis: the smallest rotation taking (0,0,1) to z.
inline Quat ZAxisToQuat(Vec3 z) {
  z = Normalized(z);
  Vec3 axis = Cross({0, 0, 1}, z);
  double s = Norm(axis);
  if (s < 1e-10) axis = {1, 0, 0};
  else axis = {axis[0] / s, axis[1] / s, axis[2] / s};
  double ang = std::atan2(s, z[2]);
  double sh = std::sin(ang / 2);
  return {std::cos(ang / 2), axis[0] * sh, axis[1] * sh, axis[2] * sh};
}

}  // namespace mlspaces::sim::internal
