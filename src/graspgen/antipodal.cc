// Systematic antipodal candidates (include/mlspaces/graspgen/antipodal.h).
#include "mlspaces/graspgen/antipodal.h"

#include <array>
#include <cmath>
#include <numbers>

#include "mlspaces/core/error.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/robots/robot_spec.h"

namespace mlspaces::graspgen {
namespace {

Vec3 Apply(const Mat4& t, const Vec3& p) {
  return {t(0, 0) * p[0] + t(0, 1) * p[1] + t(0, 2) * p[2] + t(0, 3),
          t(1, 0) * p[0] + t(1, 1) * p[1] + t(1, 2) * p[2] + t(1, 3),
          t(2, 0) * p[0] + t(2, 1) * p[1] + t(2, 2) * p[2] + t(2, 3)};
}
Vec3 Column(const Mat4& t, int c) { return {t(0, c), t(1, c), t(2, c)}; }

}  // namespace

GripperProxy FrankaDroidGripperProxy() {
  return GripperProxyOf(robots::LoadRobotSpec("franka_droid"));
}

std::vector<double> Standoffs(const CandidateParams& p) {
  if (!(p.standoff_density > 0) || !(p.standoff_min > 0) || !(p.standoff_max >= p.standoff_min)) {
    throw Error("standoffs need 0 < min <= max and a density > 0");
  }
  const int n = std::max(
      1,
      static_cast<int>(std::floor((p.standoff_max - p.standoff_min) / p.standoff_density + 1e-9)));
  std::vector<double> out;
  out.reserve(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    out.push_back(n == 1 ? p.standoff_min
                         : p.standoff_min + (p.standoff_max - p.standoff_min) * i / (n - 1));
  }
  return out;
}

std::vector<double> Rolls(const CandidateParams& p) {
  if (!(p.roll_step_deg > 0)) throw Error("roll step must be > 0 degrees");
  std::vector<double> out;
  for (int i = 0; i * p.roll_step_deg < 180 - 1e-9; ++i) {
    out.push_back(i * p.roll_step_deg * std::numbers::pi / 180);
  }
  return out;
}

Mat4 CandidateTcp(const Vec3& p, const Vec3& n, double roll, double standoff, double tcp_offset) {
  // Minimal rotation taking -z onto n (Rodrigues), so the hand's +z is -n.
  Rot3 r;
  const Vec3 v{n[1], -n[0], 0};  // (-z) x n
  const double c = -n[2];        // (-z) . n
  if (c < -1 + 1e-12) {
    r = {1, 0, 0, 0, -1, 0, 0, 0, -1};  // n = +z: half turn about x
  } else {
    const double k = 1 / (1 + c);
    const double vx[9] = {0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        double sq = 0;
        for (int m = 0; m < 3; ++m) sq += vx[3 * i + m] * vx[3 * m + j];
        r[3 * i + j] = (i == j ? 1.0 : 0.0) + vx[3 * i + j] + k * sq;
      }
    }
  }
  const double off = standoff - tcp_offset;
  Mat4 t = ToMat4(Vec3{p[0] + off * n[0], p[1] + off * n[1], p[2] + off * n[2]}, r);
  // Hand roll, then the generation frame (closing along x) -> unified (closing along y).
  return t * RotZ(roll + std::numbers::pi / 2);
}

namespace {

// The nearest hit of each finger's closing rays: 0 the +y finger (closing along -y), 1 the -y
// finger; level -1 when a finger's rays hit nothing within 2 * finger_offset.
struct FingerHit {
  double t = 1e300;
  int level = -1;
  RayHit hit;
};

std::array<FingerHit, 2> ClosingHits(const MeshBvh& bvh, const GripperProxy& g, const Mat4& tcp) {
  const Vec3 y = Column(tcp, 1);
  const double w = g.finger_offset;
  std::array<FingerHit, 2> side;
  for (size_t k = 0; k < g.ray_levels.size(); ++k) {
    for (int s = 0; s < 2; ++s) {
      const double sign = s == 0 ? 1.0 : -1.0;
      const Vec3 o = Apply(tcp, {0, sign * w, g.ray_levels[k]});
      const Vec3 d{-sign * y[0], -sign * y[1], -sign * y[2]};
      const auto hit = bvh.Raycast(o, d, 2 * w);
      if (hit && hit->t < 2 * w && hit->t < side[s].t) {
        side[s] = {hit->t, static_cast<int>(k), *hit};
      }
    }
  }
  return side;
}

}  // namespace

std::pair<double, double> AntipodalQuality(const MeshBvh& bvh, const GripperProxy& g,
                                           const Mat4& tcp) {
  const std::array<FingerHit, 2> side = ClosingHits(bvh, g, tcp);
  if (side[0].level < 0 || side[1].level < 0) return {0.0, 0.0};
  const Vec3 &cl = side[0].hit.point, &cr = side[1].hit.point;
  Vec3 u{cr[0] - cl[0], cr[1] - cl[1], cr[2] - cl[2]};
  const double len = std::sqrt(Dot(u, u));
  if (!(len > 0)) return {0.0, 0.0};
  u = {u[0] / len, u[1] / len, u[2] / len};
  const Vec3 nl = FaceNormal(bvh.mesh(), side[0].hit.face);
  const Vec3 nr = FaceNormal(bvh.mesh(), side[1].hit.face);
  const double ql = -Dot(nl, u), qr = Dot(nr, u);
  if (ql < 0 || qr < 0) return {0.0, 0.0};
  const double depth = g.ray_levels.size() > 1
                           ? 0.5 * (side[0].level + side[1].level) / (g.ray_levels.size() - 1)
                           : 0.0;
  return {std::min(ql, qr), depth};
}

Mat4 CenteredTcp(const MeshBvh& bvh, const GripperProxy& g, const Mat4& tcp) {
  const std::array<FingerHit, 2> side = ClosingHits(bvh, g, tcp);
  if (side[0].level < 0 || side[1].level < 0) return tcp;
  // Moving the hand by -delta along y shortens the +y finger's gap by delta and lengthens the
  // other's: equal gaps at delta = (t0 - t1) / 2.
  const double delta = 0.5 * (side[0].t - side[1].t);
  Mat4 out = tcp;
  for (int r = 0; r < 3; ++r) out(r, 3) -= delta * tcp(r, 1);
  return out;
}

bool HandCollides(const MeshBvh& bvh, const GripperProxy& g, const Mat4& tcp) {
  for (const OrientedBox& b : g.boxes) {
    OrientedBox w;
    w.center = Apply(tcp, b.center);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        double s = 0;
        for (int m = 0; m < 3; ++m) s += tcp(i, m) * b.rot[3 * m + j];
        w.rot[3 * i + j] = s;
      }
    }
    w.half = b.half;
    if (bvh.Overlaps(w)) return true;
  }
  return false;
}

CandidateSet GenerateCandidates(const MeshBvh& bvh, const GripperProxy& g,
                                const CandidateParams& params, uint64_t seed,
                                const MeshBvh* obstacles) {
  const SurfaceSamples samples = SampleSurface(bvh.mesh(), params.surface_density, seed);
  const std::vector<double> standoffs = Standoffs(params), rolls = Rolls(params);
  const double smax = *std::max_element(standoffs.begin(), standoffs.end());
  CandidateSet out;
  out.stats.points = samples.points.size();
  out.stats.raw = samples.points.size() * standoffs.size() * rolls.size();
  constexpr size_t kChunk = 32;
  const size_t chunks = (samples.points.size() + kChunk - 1) / kChunk;
  struct Chunk {
    std::vector<GraspCandidate> kept;
    CandidateStats stats;
  };
  ParallelForOrdered<Chunk>(
      chunks, params.threads, 64,
      [&](size_t c) {
        Chunk r;
        const size_t end = std::min(samples.points.size(), (c + 1) * kChunk);
        for (size_t i = c * kChunk; i < end; ++i) {
          const Vec3 &p = samples.points[i], &n = samples.normals[i];
          // Visibility (spec 2.4.2 step 5): the ray from the hand origin back to p meets
          // nothing first, i.e. nothing lies within `standoff` of p along the normal.
          constexpr double kEps = 1e-6;
          const auto block =
              bvh.Raycast({p[0] + kEps * n[0], p[1] + kEps * n[1], p[2] + kEps * n[2]}, n, smax);
          const double free = block ? block->t + kEps : 1e300;
          for (double roll : rolls) {
            for (double s : standoffs) {
              if (s >= free) continue;
              ++r.stats.visible;
              const Mat4 tcp = CandidateTcp(p, n, roll, s, params.tcp_offset);
              if (HandCollides(bvh, g, tcp)) continue;
              if (obstacles != nullptr && HandCollides(*obstacles, g, tcp)) continue;
              ++r.stats.collision_free;
              const auto [q, depth] = AntipodalQuality(bvh, g, tcp);
              if (q < params.min_quality) continue;
              r.kept.push_back({tcp, q, depth, p, n, roll, s});
            }
          }
        }
        r.stats.kept = r.kept.size();
        return r;
      },
      [&](size_t, Chunk&& r) {
        out.stats.visible += r.stats.visible;
        out.stats.collision_free += r.stats.collision_free;
        out.stats.kept += r.stats.kept;
        out.candidates.insert(out.candidates.end(), r.kept.begin(), r.kept.end());
      });
  return out;
}

}  // namespace mlspaces::graspgen
