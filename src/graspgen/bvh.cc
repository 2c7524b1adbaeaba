// MeshBvh: ray casts and oriented-box overlap over a triangle mesh
// (include/mlspaces/graspgen/mesh.h).
#include <algorithm>
#include <cmath>
#include <limits>

#include "mlspaces/graspgen/mesh.h"

namespace mlspaces::graspgen {
namespace {

constexpr int kLeafSize = 4;

// Moller-Trumbore, both sides; t in [0, tmax] or nothing.
std::optional<double> RayTriangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b,
                                  const Vec3& c, double tmax) {
  const Vec3 e1 = Sub(b, a), e2 = Sub(c, a);
  const Vec3 p = Cross(d, e2);
  const double det = Dot(e1, p);
  if (std::abs(det) < 1e-18) return std::nullopt;
  const double inv = 1.0 / det;
  const Vec3 s = Sub(o, a);
  const double u = Dot(s, p) * inv;
  if (u < 0 || u > 1) return std::nullopt;
  const Vec3 q = Cross(s, e1);
  const double v = Dot(d, q) * inv;
  if (v < 0 || u + v > 1) return std::nullopt;
  const double t = Dot(e2, q) * inv;
  if (t < 0 || t > tmax) return std::nullopt;
  return t;
}

// Slab test: does the ray enter the box before tmax?
bool RayBox(const Vec3& o, const Vec3& inv, const Vec3& lo, const Vec3& hi, double tmax) {
  double t0 = 0, t1 = tmax;
  for (int k = 0; k < 3; ++k) {
    double a = (lo[k] - o[k]) * inv[k], b = (hi[k] - o[k]) * inv[k];
    if (a > b) std::swap(a, b);
    if (!(a <= t1) || !(b >= t0)) {
      // NaN (0 * inf: origin on a slab plane, direction parallel) counts as inside the slab.
      if (std::isnan(a) || std::isnan(b)) continue;
      return false;
    }
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1;
}

// Triangle (in the box frame) against an axis-aligned box of half sizes h at the origin:
// the 13 separating axes of Akenine-Moller's test.
bool TriangleBox(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& h) {
  const Vec3 e[3] = {Sub(v1, v0), Sub(v2, v1), Sub(v0, v2)};
  auto separated = [&](const Vec3& axis) {
    const double p0 = Dot(v0, axis), p1 = Dot(v1, axis), p2 = Dot(v2, axis);
    const double r = h[0] * std::abs(axis[0]) + h[1] * std::abs(axis[1]) + h[2] * std::abs(axis[2]);
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
  };
  for (int k = 0; k < 3; ++k) {
    Vec3 axis{0, 0, 0};
    axis[k] = 1;
    if (separated(axis)) return false;
  }
  if (separated(Cross(e[0], e[1]))) return false;
  for (const Vec3& edge : e) {
    for (int k = 0; k < 3; ++k) {
      Vec3 unit{0, 0, 0};
      unit[k] = 1;
      const Vec3 axis = Cross(unit, edge);
      if (Dot(axis, axis) < 1e-30) continue;
      if (separated(axis)) return false;
    }
  }
  return true;
}

}  // namespace

MeshBvh::MeshBvh(TriMesh mesh) : mesh_(std::move(mesh)) {
  const auto n = static_cast<int32_t>(mesh_.faces.size());
  order_.resize(n);
  centroids_.resize(n);
  for (int32_t f = 0; f < n; ++f) {
    order_[f] = f;
    const auto& t = mesh_.faces[f];
    for (int k = 0; k < 3; ++k) {
      centroids_[f][k] =
          (mesh_.vertices[t[0]][k] + mesh_.vertices[t[1]][k] + mesh_.vertices[t[2]][k]) / 3;
    }
  }
  nodes_.reserve(n > 0 ? 2 * n / kLeafSize + 1 : 1);
  if (n > 0) Build(0, n);
}

int32_t MeshBvh::Build(int32_t begin, int32_t end) {
  const auto id = static_cast<int32_t>(nodes_.size());
  nodes_.push_back({});
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Vec3 lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf}, clo = lo, chi = hi;
  for (int32_t i = begin; i < end; ++i) {
    for (int32_t v : mesh_.faces[order_[i]]) {
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], mesh_.vertices[v][k]);
        hi[k] = std::max(hi[k], mesh_.vertices[v][k]);
      }
    }
    for (int k = 0; k < 3; ++k) {
      clo[k] = std::min(clo[k], centroids_[order_[i]][k]);
      chi[k] = std::max(chi[k], centroids_[order_[i]][k]);
    }
  }
  nodes_[id] = {lo, hi, begin, end - begin};
  if (end - begin <= kLeafSize) return id;
  int axis = 0;
  for (int k = 1; k < 3; ++k) {
    if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
  }
  const int32_t mid = begin + (end - begin) / 2;
  // Ties broken by face index, so the tree does not depend on the sort implementation.
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int32_t a, int32_t b) {
                     return centroids_[a][axis] != centroids_[b][axis]
                                ? centroids_[a][axis] < centroids_[b][axis]
                                : a < b;
                   });
  Build(begin, mid);
  const int32_t right = Build(mid, end);
  nodes_[id].first = right;
  nodes_[id].count = 0;
  return id;
}

std::optional<RayHit> MeshBvh::Raycast(const Vec3& o, const Vec3& d, double tmax) const {
  if (nodes_.empty()) return std::nullopt;
  const Vec3 inv{1.0 / d[0], 1.0 / d[1], 1.0 / d[2]};
  std::optional<RayHit> best;
  double limit = tmax;
  int32_t stack[64];
  int sp = 0;
  stack[sp++] = 0;
  while (sp > 0) {
    const Node& node = nodes_[stack[--sp]];
    if (!RayBox(o, inv, node.lo, node.hi, limit)) continue;
    if (node.count > 0) {
      for (int32_t i = node.first; i < node.first + node.count; ++i) {
        const int32_t f = order_[i];
        const auto& t = mesh_.faces[f];
        const auto hit = RayTriangle(o, d, mesh_.vertices[t[0]], mesh_.vertices[t[1]],
                                     mesh_.vertices[t[2]], limit);
        // Equal distances: the lower face index wins (deterministic whatever the tree).
        if (hit && (!best || *hit < best->t || (*hit == best->t && f < best->face))) {
          best = RayHit{*hit, f, {o[0] + *hit * d[0], o[1] + *hit * d[1], o[2] + *hit * d[2]}};
          limit = *hit;
        }
      }
    } else {
      const int32_t self = static_cast<int32_t>(&node - nodes_.data());
      stack[sp++] = node.first;  // right
      stack[sp++] = self + 1;    // left (built right after its parent)
    }
  }
  return best;
}

bool MeshBvh::Overlaps(const OrientedBox& box) const {
  if (nodes_.empty()) return false;
  // World AABB of the box.
  Vec3 ext;
  for (int r = 0; r < 3; ++r) {
    ext[r] = std::abs(box.rot[3 * r]) * box.half[0] + std::abs(box.rot[3 * r + 1]) * box.half[1] +
             std::abs(box.rot[3 * r + 2]) * box.half[2];
  }
  auto to_box = [&](const Vec3& p) {  // rot^T (p - center)
    const Vec3 q = Sub(p, box.center);
    return Vec3{box.rot[0] * q[0] + box.rot[3] * q[1] + box.rot[6] * q[2],
                box.rot[1] * q[0] + box.rot[4] * q[1] + box.rot[7] * q[2],
                box.rot[2] * q[0] + box.rot[5] * q[1] + box.rot[8] * q[2]};
  };
  int32_t stack[64];
  int sp = 0;
  stack[sp++] = 0;
  while (sp > 0) {
    const int32_t id = stack[--sp];
    const Node& node = nodes_[id];
    bool apart = false;
    for (int k = 0; k < 3; ++k) {
      apart |= node.lo[k] > box.center[k] + ext[k] || node.hi[k] < box.center[k] - ext[k];
    }
    if (apart) continue;
    if (node.count > 0) {
      for (int32_t i = node.first; i < node.first + node.count; ++i) {
        const auto& t = mesh_.faces[order_[i]];
        if (TriangleBox(to_box(mesh_.vertices[t[0]]), to_box(mesh_.vertices[t[1]]),
                        to_box(mesh_.vertices[t[2]]), box.half)) {
          return true;
        }
      }
    } else {
      stack[sp++] = node.first;
      stack[sp++] = id + 1;
    }
  }
  return false;
}

std::optional<RayHit> RaycastBruteForce(const TriMesh& mesh, const Vec3& o, const Vec3& d,
                                        double tmax) {
  std::optional<RayHit> best;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    const auto hit =
        RayTriangle(o, d, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], tmax);
    if (hit && (!best || *hit < best->t)) {
      best = RayHit{*hit,
                    static_cast<int32_t>(f),
                    {o[0] + *hit * d[0], o[1] + *hit * d[1], o[2] + *hit * d[2]}};
    }
  }
  return best;
}

}  // namespace mlspaces::graspgen
