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

}  // namespace

ShadowFit FitShadowMaps(const mjModel* m, mjvScene* scn, mjrContext* con, float default_clip) {
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

  // Per light, the casters' outline in MuJoCo's light frame (mjr_render: mjr_lookAt from the
  // light along its direction, up = mjr_orthoVec(direction)).
  struct Placed {
    int light;
    double pos[3];
  };
  std::vector<Placed> placed;
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
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    const Vec3* axes[3] = {&side, &top, &f};
    for (const Box& b : boxes) {
      for (int a = 0; a < 3; ++a) {
        const double c = Dot(b.c, *axes[a]), h = Support(b, *axes[a]);
        lo[a] = std::min(lo[a], c - h);
        hi[a] = std::max(hi[a], c + h);
      }
    }
    if (boxes.empty()) continue;  // nothing casts: the light stays where it is
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
  fit.clip = con->shadowClip;
  fit.planes_skipped = static_cast<int>(skip.size());
  return fit;
}

}  // namespace mlspaces::sim
