#include "mlspaces/core/transform.h"

#include <cmath>

namespace mlspaces {

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

Mat4 PoseToMat4(const std::array<double, 3>& pos, const std::array<double, 4>& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  std::array<double, 9> r{1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
  return PoseToMat4(pos, r);
}

Mat4 PoseToMat4(const std::array<double, 3>& pos, const std::array<double, 9>& rot) {
  Mat4 out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = rot[r * 3 + c];
    out(r, 3) = pos[r];
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

}  // namespace mlspaces
