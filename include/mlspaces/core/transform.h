// Small rigid-transform math: 4x4 homogeneous matrices, row-major, metres.
#pragma once

#include <array>

namespace mlspaces {

/// Row-major 4x4 homogeneous transform: m[r*4 + c]. Default is the identity.
struct Mat4 {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double& operator()(int r, int c) { return m[r * 4 + c]; }
  double operator()(int r, int c) const { return m[r * 4 + c]; }
};

Mat4 operator*(const Mat4& a, const Mat4& b);
/// Transform from a position and a unit quaternion (w, x, y, z), MuJoCo's order.
Mat4 PoseToMat4(const std::array<double, 3>& pos, const std::array<double, 4>& quat_wxyz);
/// Transform from a position and a row-major 3x3 rotation (MuJoCo's xmat layout).
Mat4 PoseToMat4(const std::array<double, 3>& pos, const std::array<double, 9>& rot_rowmajor);
/// Rotation of `angle` radians about the local z axis.
Mat4 RotZ(double angle);
/// Inverse of a rigid transform.
Mat4 InverseRigid(const Mat4& t);

}  // namespace mlspaces
