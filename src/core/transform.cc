#include "mlspaces/core/transform.h"

#include <algorithm>
#include <cmath>

namespace mlspaces {

// ---- Quaternions ---------------------------------------------------------------------------

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

Rot3 QuatToRotation(const Quat& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

Quat QuatFromRotation(const Rot3& r) {
  auto p = [&r](int i, int j) { return r[3 * i + j]; };
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

// ---- Mat4 ----------------------------------------------------------------------------------

Mat4 operator*(const Mat4& a, const Mat4& b) {
  Mat4 out;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a(r, k) * b(k, c);
      out(r, c) = s;
    }
  }
  return out;
}

Mat4 RotZ(double angle) {
  Mat4 out;
  const double c = std::cos(angle), s = std::sin(angle);
  out(0, 0) = c;
  out(0, 1) = -s;
  out(1, 0) = s;
  out(1, 1) = c;
  return out;
}

Mat4 AxisAngle(const Vec3& a, double angle) {
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  Mat4 r;
  r(0, 0) = c + a[0] * a[0] * t;
  r(0, 1) = a[0] * a[1] * t - a[2] * s;
  r(0, 2) = a[0] * a[2] * t + a[1] * s;
  r(1, 0) = a[1] * a[0] * t + a[2] * s;
  r(1, 1) = c + a[1] * a[1] * t;
  r(1, 2) = a[1] * a[2] * t - a[0] * s;
  r(2, 0) = a[2] * a[0] * t - a[1] * s;
  r(2, 1) = a[2] * a[1] * t + a[0] * s;
  r(2, 2) = c + a[2] * a[2] * t;
  return r;
}

Mat4 Translate(const Vec3& v) {
  Mat4 t;
  for (int k = 0; k < 3; ++k) t(k, 3) = v[k];
  return t;
}

Mat4 InverseRigid(const Mat4& t) {
  Mat4 out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = t(c, r);
  }
  for (int r = 0; r < 3; ++r) {
    out(r, 3) = -(out(r, 0) * t(0, 3) + out(r, 1) * t(1, 3) + out(r, 2) * t(2, 3));
  }
  return out;
}

Vec3 Translation(const Mat4& t) { return {t(0, 3), t(1, 3), t(2, 3)}; }

Rot3 Rotation(const Mat4& t) {
  Rot3 r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[3 * i + j] = t(i, j);
  }
  return r;
}

Quat QuatFromMat4(const Mat4& t) { return QuatFromRotation(Rotation(t)); }

// ---- Conversions ---------------------------------------------------------------------------

Mat4 ToMat4(const Pose& pose) { return ToMat4(pose.pos, QuatToRotation(pose.quat)); }

Mat4 ToMat4(const Vec3& pos, const Rot3& rot) {
  Mat4 out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = rot[r * 3 + c];
    out(r, 3) = pos[r];
  }
  return out;
}

Pose ToPose(const Mat4& t) { return {Translation(t), QuatFromMat4(t)}; }

Array7 ToArray7(const Pose& pose) {
  return {pose.pos[0],  pose.pos[1],  pose.pos[2], pose.quat[0],
          pose.quat[1], pose.quat[2], pose.quat[3]};
}

Pose FromArray7(const Array7& a) { return {{a[0], a[1], a[2]}, {a[3], a[4], a[5], a[6]}}; }

}  // namespace mlspaces
