// Rigid-transform math, one type per idea:
//  - Pose: a position (m) and a unit quaternion (w, x, y, z), MuJoCo's order. What bodies,
//    sites, robot bases and task poses are.
//  - Mat4: the same rigid transform as a row-major 4x4 homogeneous matrix: what grasp arrays
//    store and what composes (operator*, InverseRigid).
//  - The 7-vector [x, y, z, qw, qx, qy, qz] (position, then quaternion), for datasets and
//    configs: ToArray7 / FromArray7 (the layout is the dataset format's, see docs/formats.md).
// Quaternion helpers (multiply, conjugate, normalise, slerp, to/from rotation matrices) live
// here too; SE(3) interpolation and timing in core/se3.h; MuJoCo's xpos/xquat/xmat arrays
// convert in sim/mj_pose.h.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cmath>

namespace mlspaces {

using Vec3 = std::array<double, 3>;
/// Quaternion (w, x, y, z), MuJoCo's order.
using Quat = std::array<double, 4>;
/// Row-major 3x3 rotation (MuJoCo's xmat layout).
using Rot3 = std::array<double, 9>;
/// [x, y, z, qw, qx, qy, qz]: the 7-vector pose layout (docs/formats.md).
using Array7 = std::array<double, 7>;

/// a - b.
inline Vec3 Sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
/// a . b.
inline double Dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
/// a x b.
inline Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
/// |a|.
inline double Norm(const Vec3& a) { return std::sqrt(Dot(a, a)); }

/// Row-major 4x4 homogeneous transform: m[r*4 + c]. Default is the identity.
struct MLSPACES_API Mat4 {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double& operator()(int r, int c) { return m[r * 4 + c]; }
  double operator()(int r, int c) const { return m[r * 4 + c]; }
};

/// A rigid pose: position (m) and unit quaternion (w, x, y, z). Default is the identity.
struct MLSPACES_API Pose {
  Vec3 pos{0, 0, 0};
  Quat quat{1, 0, 0, 0};
  bool operator==(const Pose&) const = default;
};

// ---- Quaternions ---------------------------------------------------------------------------

MLSPACES_API Quat QuatMul(const Quat& a, const Quat& b);
MLSPACES_API Quat QuatConjugate(const Quat& q);
/// q / |q|; the identity for a zero (or non-finite-norm) quaternion.
MLSPACES_API Quat QuatNormalized(const Quat& q);
/// Spherical linear interpolation along the shorter arc; t in [0, 1]. Falls back to a
/// normalised lerp when the quaternions are nearly equal. Always returns a unit quaternion.
MLSPACES_API Quat Slerp(const Quat& a, Quat b, double t);
/// Row-major rotation of a unit quaternion (not normalised here).
MLSPACES_API Rot3 QuatToRotation(const Quat& q);
/// Unit quaternion with w >= 0 of a row-major rotation (Shepperd's method).
MLSPACES_API Quat QuatFromRotation(const Rot3& r);

// ---- Mat4 ----------------------------------------------------------------------------------

MLSPACES_API Mat4 operator*(const Mat4& a, const Mat4& b);
/// Rotation of `angle` radians about the local z axis.
MLSPACES_API Mat4 RotZ(double angle);
/// Rotation of `angle` radians about the unit axis `axis` (Rodrigues).
MLSPACES_API Mat4 AxisAngle(const Vec3& axis, double angle);
/// The pure translation by `v`.
MLSPACES_API Mat4 Translate(const Vec3& v);
/// Inverse of a rigid transform.
MLSPACES_API Mat4 InverseRigid(const Mat4& t);
/// Position part of a transform.
MLSPACES_API Vec3 Translation(const Mat4& t);
/// Rotation block of a transform, row-major.
MLSPACES_API Rot3 Rotation(const Mat4& t);
/// Rotation part of a transform as a unit quaternion with w >= 0 (Shepperd's method).
MLSPACES_API Quat QuatFromMat4(const Mat4& t);

// ---- Conversions ---------------------------------------------------------------------------

/// The matrix of a pose (its quaternion taken as given: not normalised).
MLSPACES_API Mat4 ToMat4(const Pose& pose);
/// The matrix of a position and a row-major rotation (MuJoCo's xpos + xmat).
MLSPACES_API Mat4 ToMat4(const Vec3& pos, const Rot3& rot);
/// The pose of a matrix: its translation and QuatFromMat4 (w >= 0).
MLSPACES_API Pose ToPose(const Mat4& t);
/// [x, y, z, qw, qx, qy, qz].
MLSPACES_API Array7 ToArray7(const Pose& pose);
/// The pose of [x, y, z, qw, qx, qy, qz], taken as given (not normalised).
MLSPACES_API Pose FromArray7(const Array7& a);

}  // namespace mlspaces
