#include "mlspaces/sim/shadow_fit.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "mlspaces/core/transform.h"

namespace mlspaces::sim {
namespace {

using mlspaces::Cross;
using mlspaces::Dot;
using mlspaces::Norm;
using mlspaces::Vec3;

// An oriented box holding a scene geom: centre, the geom frame's axes, half sizes along them.
struct Box {
  Vec3 c;
  Vec3 axis[3];  // axis[k] = column k of the geom's rotation
  double half[3];
};

// The box of scene geom `g`, or false when its extent is unknown (planes, flexes, skins,
// meshes and height fields that are no model geom).
bool GeomBox(const mjModel* m, const mjvGeom& g, Box* b) {
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 3; ++i) b->axis[k][i] = g.mat[3 * i + k];
  }
  double local[3] = {0, 0, 0};
  const float* s = g.size;
  if (g.objtype == mjOBJ_GEOM && g.objid >= 0 && g.objid < m->ngeom &&
      m->geom_type[g.objid] == g.type && g.type != mjGEOM_PLANE) {
    const mjtNum* aabb = m->geom_aabb + 6 * g.objid;  // centre, then half sizes, geom frame
    for (int k = 0; k < 3; ++k) {
      local[k] = aabb[k];
      b->half[k] = aabb[3 + k];
    }
  } else {
    switch (g.type) {
      case mjGEOM_SPHERE:
        b->half[0] = b->half[1] = b->half[2] = s[0];
        break;
      case mjGEOM_CAPSULE:
        b->half[0] = b->half[1] = s[0];
        b->half[2] = s[0] + s[2];
        break;
      case mjGEOM_CYLINDER:
        b->half[0] = b->half[1] = s[0];
        b->half[2] = s[2];
        break;
      case mjGEOM_ELLIPSOID:
      case mjGEOM_BOX:
        for (int k = 0; k < 3; ++k) b->half[k] = s[k];
        break;
      default:
        return false;
    }
  }
  for (int i = 0; i < 3; ++i) {
    b->c[i] = g.pos[i];
    for (int k = 0; k < 3; ++k) b->c[i] += b->axis[k][i] * local[k];
  }
  return true;
}

// Half extent of box `b` along unit vector `n`.
double Support(const Box& b, const Vec3& n) {
  return std::abs(Dot(b.axis[0], n)) * b.half[0] + std::abs(Dot(b.axis[1], n)) * b.half[1] +
         std::abs(Dot(b.axis[2], n)) * b.half[2];
}

bool Normalize(Vec3* v) {
  const double n = Norm(*v);
  if (!(n > 1e-12)) return false;
  for (double& x : *v) x /= n;
  return true;
}

Vec3 Column2(const float* mat) { return {mat[2], mat[5], mat[8]}; }

bool Casts(const mjvGeom& g) { return g.type != mjGEOM_LINE && g.category != mjCAT_DECOR; }

// True when nothing of the scene but plane `p` itself lies behind plane `p` (1 mm allowed).
// `boxes[j]`: geom j's box (none: unknown, or a plane or line).
bool NothingBehind(const mjvScene* scn, int p, const std::vector<std::optional<Box>>& boxes) {
  constexpr double kSlack = 1e-3;
  const mjvGeom& plane = scn->geoms[p];
  const Vec3 n = Column2(plane.mat);
  const Vec3 o = {plane.pos[0], plane.pos[1], plane.pos[2]};
  for (int j = 0; j < scn->ngeom; ++j) {
    const mjvGeom& g = scn->geoms[j];
    if (j == p || g.type == mjGEOM_LINE || g.type == mjGEOM_LINEBOX) continue;
    if (g.type == mjGEOM_PLANE) {
      const Vec3 d = {g.pos[0] - o[0], g.pos[1] - o[1], g.pos[2] - o[2]};
      if (std::abs(Dot(n, Column2(g.mat))) < 1 - 1e-9 || Dot(n, d) < -kSlack) return false;
      continue;
    }
    const std::optional<Box>& b = boxes[j];
    if (!b || Dot(n, Sub(b->c, o)) - Support(*b, n) < -kSlack) return false;
  }
  return true;
}

// A view's frustum: its corners and its six planes (n . x >= d inside).
struct Frustum {
  Vec3 corner[8];  // [near/far][left/right][bottom/top] as 4 * far + 2 * right + top
  Vec3 n[6];
  double d[6];
};

bool MakeFrustum(const ShadowView& v, Frustum* f) {
  const mjvGLCamera& c = v.camera;
  Vec3 fw = {c.forward[0], c.forward[1], c.forward[2]}, up = {c.up[0], c.up[1], c.up[2]};
  if (!Normalize(&fw) || !Normalize(&up)) return false;
  Vec3 right = Cross(fw, up);
  if (!Normalize(&right)) return false;
  const double near = c.frustum_near, far = c.frustum_far;
  const double hw =
      c.frustum_width > 0 ? c.frustum_width : 0.5 * v.aspect * (c.frustum_top - c.frustum_bottom);
  if (!(near > 0 && far > near && hw > 0 && c.frustum_top > c.frustum_bottom)) return false;
  for (int i = 0; i < 8; ++i) {
    const double dist = (i & 4) != 0 ? far : near;
    const double scale = c.orthographic != 0 ? 1 : dist / near;
    const double x = c.frustum_center + ((i & 2) != 0 ? hw : -hw);
    const double y = (i & 1) != 0 ? c.frustum_top : c.frustum_bottom;
    for (int k = 0; k < 3; ++k) {
      f->corner[i][k] = c.pos[k] + dist * fw[k] + scale * (x * right[k] + y * up[k]);
    }
  }
  Vec3 mid = {0, 0, 0};
  for (const Vec3& p : f->corner) {
    for (int k = 0; k < 3; ++k) mid[k] += p[k] / 8;
  }
  // Three corners of each face: near, far, left, right, bottom, top.
  constexpr int kFace[6][3] = {{0, 1, 2}, {4, 5, 6}, {0, 1, 4}, {2, 3, 6}, {0, 2, 4}, {1, 3, 5}};
  for (int i = 0; i < 6; ++i) {
    const Vec3& p0 = f->corner[kFace[i][0]];
    Vec3 n = Cross(Sub(f->corner[kFace[i][1]], p0), Sub(f->corner[kFace[i][2]], p0));
    if (!Normalize(&n)) return false;
    double d = Dot(n, p0);
    if (Dot(n, mid) < d) {
      for (double& x : n) x = -x;
      d = -d;
    }
    f->n[i] = n;
    f->d[i] = d;
  }
  return true;
}

// False when box `b` lies wholly outside one of the frustum's planes.
bool MayMeet(const Frustum& f, const Box& b) {
  for (int i = 0; i < 6; ++i) {
    if (Dot(f.n[i], b.c) + Support(b, f.n[i]) < f.d[i] - 1e-9) return false;
  }
  return true;
}

// The corners of plane geom `g`'s drawn rectangle inside the frustum (Sutherland-Hodgman).
std::vector<Vec3> PlaneInside(const Frustum& f, const mjvGeom& g) {
  const double far = Norm(Sub(f.corner[7], f.corner[0]));  // more than the view reaches
  const double sx = g.size[0] > 0 ? g.size[0] : far, sy = g.size[1] > 0 ? g.size[1] : far;
  std::vector<Vec3> poly;
  for (const auto& [a, b] : {std::pair{-1, -1}, std::pair{1, -1}, std::pair{1, 1}, {-1, 1}}) {
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = g.pos[k] + a * sx * g.mat[3 * k] + b * sy * g.mat[3 * k + 1];
    poly.push_back(p);
  }
  for (int i = 0; i < 6 && !poly.empty(); ++i) {
    std::vector<Vec3> out;
    for (size_t j = 0; j < poly.size(); ++j) {
      const Vec3& p = poly[j];
      const Vec3& q = poly[(j + 1) % poly.size()];
      const double dp = Dot(f.n[i], p) - f.d[i], dq = Dot(f.n[i], q) - f.d[i];
      if (dp >= 0) out.push_back(p);
      if ((dp >= 0) != (dq >= 0)) {
        const double t = dp / (dp - dq);
        out.push_back(
            {p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2])});
      }
    }
    poly = std::move(out);
  }
  return poly;
}

// What one view sees, as far as shadows go: the boxes of the geoms that may be in it and the
// points of the planes' parts inside it.
struct Seen {
  std::vector<int> boxes;  // geom indices
  std::vector<Vec3> points;
};

// A view's region seen along a light: the box of its receivers on the light's axes.
struct Region {
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
};

}  // namespace

ShadowFit FitShadowMaps(const mjModel* m, mjvScene* scn, mjrContext* con, float default_clip,
                        const std::vector<ShadowView>& views) {
  ShadowFit fit;
  con->shadowClip = default_clip;
  if (m == nullptr || !scn->flags[mjRND_SHADOW]) return fit;
  const int nlight = std::min(scn->nlight, static_cast<int>(mjMAXLIGHT));
  bool any = false;
  for (int i = 0; i < nlight; ++i) {
    any = any || (scn->lights[i].castshadow && scn->lights[i].type == mjLIGHT_DIRECTIONAL);
  }
  if (!any) return fit;

  // Every geom's box, once; the casters' boxes; planes with nothing behind them stop casting.
  std::vector<std::optional<Box>> all(scn->ngeom);
  for (int j = 0; j < scn->ngeom; ++j) {
    Box b;
    if (GeomBox(m, scn->geoms[j], &b)) all[j] = b;
  }
  std::vector<int> skip;
  std::vector<Box> boxes;
  boxes.reserve(scn->ngeom);
  for (int j = 0; j < scn->ngeom; ++j) {
    const mjvGeom& g = scn->geoms[j];
    if (!Casts(g)) continue;
    if (g.type == mjGEOM_PLANE) {
      if (!NothingBehind(scn, j, all)) return fit;
      skip.push_back(j);
      continue;
    }
    if (!all[j]) return fit;
    boxes.push_back(*all[j]);
  }

  // What each view sees (none: every caster counts).
  std::vector<Seen> seen;
  for (const ShadowView& v : views) {
    Frustum f;
    Seen s;
    bool known = MakeFrustum(v, &f);
    for (int j = 0; known && j < scn->ngeom; ++j) {
      const mjvGeom& g = scn->geoms[j];
      if (g.type == mjGEOM_LINE || g.type == mjGEOM_LINEBOX) continue;  // unlit
      if (g.type == mjGEOM_PLANE) {
        const std::vector<Vec3> inside = PlaneInside(f, g);
        s.points.insert(s.points.end(), inside.begin(), inside.end());
      } else if (!all[j]) {
        known = false;
      } else if (MayMeet(f, *all[j])) {
        s.boxes.push_back(j);
      }
    }
    if (!known) {
      seen.clear();
      break;
    }
    seen.push_back(std::move(s));
  }

  // Per light, the casters' outline in MuJoCo's light frame (mjr_render: mjr_lookAt from the
  // light along its direction, up = mjr_orthoVec(direction)).
  struct Placed {
    int light;
    double pos[3];
  };
  std::vector<Placed> placed;
  std::vector<char> in_a_square(boxes.size(), 0);
  double clip = 0;
  for (int i = 0; i < nlight; ++i) {
    const mjvLight& l = scn->lights[i];
    if (!l.castshadow || l.type != mjLIGHT_DIRECTIONAL) continue;
    Vec3 f = {l.dir[0], l.dir[1], l.dir[2]};
    if (!Normalize(&f)) return fit;
    Vec3 up = Cross(f, {-1, 0, 0});
    if (Dot(up, up) <= 0.01) up = Cross(f, {0, 1, 0});
    if (!Normalize(&up)) return fit;
    Vec3 side = Cross(f, up);
    if (!Normalize(&side)) return fit;
    Vec3 top = Cross(side, f);
    if (!Normalize(&top)) return fit;
    const Vec3* axes[3] = {&side, &top, &f};
    // Each view's receivers along this light; a caster counts when it may stand between the
    // light and one of them: its outline meets theirs and it begins before they end.
    std::vector<Region> regions(seen.size());
    for (size_t v = 0; v < seen.size(); ++v) {
      Region& r = regions[v];
      auto add = [&r](int a, double lo, double hi) {
        if (a < 2) r.lo[a] = std::min(r.lo[a], lo);
        r.hi[a] = std::max(r.hi[a], hi);
      };
      for (const int j : seen[v].boxes) {
        for (int a = 0; a < 3; ++a) {
          const double c = Dot(all[j]->c, *axes[a]), h = Support(*all[j], *axes[a]);
          add(a, c - h, c + h);
        }
      }
      for (const Vec3& p : seen[v].points) {
        for (int a = 0; a < 3; ++a) add(a, Dot(p, *axes[a]), Dot(p, *axes[a]));
      }
    }
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    int counted = 0;
    for (size_t c = 0; c < boxes.size(); ++c) {
      const Box& b = boxes[c];
      double blo[3], bhi[3];
      for (int a = 0; a < 3; ++a) {
        const double mid = Dot(b.c, *axes[a]), h = Support(b, *axes[a]);
        blo[a] = mid - h;
        bhi[a] = mid + h;
      }
      bool counts = seen.empty();
      for (const Region& r : regions) {
        constexpr double kSlack = 1e-6;
        counts = counts || (blo[0] <= r.hi[0] + kSlack && bhi[0] >= r.lo[0] - kSlack &&
                            blo[1] <= r.hi[1] + kSlack && bhi[1] >= r.lo[1] - kSlack &&
                            blo[2] <= r.hi[2] + kSlack);
      }
      if (!counts) continue;
      ++counted;
      in_a_square[c] = 1;
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], blo[a]);
        hi[a] = std::max(hi[a], bhi[a]);
      }
    }
    if (counted == 0) continue;  // nothing casts: the light stays where it is
    const double cs = 0.5 * (lo[0] + hi[0]), ct = 0.5 * (lo[1] + hi[1]);
    clip = std::max({clip, 0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1])});
    // Behind every caster by a tenth of the model's size, so none meets the near plane.
    const double back = lo[2] - 0.1 * m->stat.extent;
    Placed p{i, {0, 0, 0}};
    for (int k = 0; k < 3; ++k) p.pos[k] = cs * side[k] + ct * top[k] + back * f[k];
    placed.push_back(p);
  }

  // The map's outermost texels stay empty (mjr_render draws into 1..size-2): two more texels
  // of margin on each side; no casters: a tiny empty square.
  const int size = std::max(con->shadowSize, 8);
  clip = clip * size / (size - 4.0);
  if (!(clip > 0)) clip = 1e-3 * std::max(m->stat.extent, 1e-3);
  for (const Placed& p : placed) {
    for (int k = 0; k < 3; ++k) scn->lights[p.light].pos[k] = static_cast<float>(p.pos[k]);
  }
  for (const int j : skip) scn->geoms[j].category = mjCAT_DECOR;
  con->shadowClip = static_cast<float>(clip);
  fit.fitted = true;
  fit.casters_unseen = static_cast<int>(std::count(in_a_square.begin(), in_a_square.end(), 0));
  fit.clip = con->shadowClip;
  fit.planes_skipped = static_cast<int>(skip.size());
  return fit;
}

}  // namespace mlspaces::sim
