#include "mlspaces/sim/asset_facts.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/sim/mjcf_composer.h"

namespace mlspaces::sim {
namespace {

struct Box {
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-std::numeric_limits<double>::infinity(),
                  -std::numeric_limits<double>::infinity(),
                  -std::numeric_limits<double>::infinity()};
  bool empty = true;
  void Add(const double p[3]) {
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], p[i]);
      hi[i] = std::max(hi[i], p[i]);
    }
    empty = false;
  }
  void AddCentered(const double c[3], const double half[3]) {
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], c[i] - half[i]);
      hi[i] = std::max(hi[i], c[i] + half[i]);
    }
    empty = false;
  }
};

// Point c + R * local, R row-major (MuJoCo xmat).
void Xform(const double* xpos, const double* xmat, const double local[3], double out[3]) {
  for (int i = 0; i < 3; ++i) {
    out[i] =
        xpos[i] + xmat[3 * i] * local[0] + xmat[3 * i + 1] * local[1] + xmat[3 * i + 2] * local[2];
  }
}

void AddCorners(const double* xpos, const double* xmat, const double half[3], const double lo_z,
                const double hi_z, Box* box) {
  for (int c = 0; c < 8; ++c) {
    double local[3] = {(c & 1) ? half[0] : -half[0], (c & 2) ? half[1] : -half[1],
                       (c & 4) ? hi_z : lo_z};
    double w[3];
    Xform(xpos, xmat, local, w);
    box->Add(w);
  }
}

void AddGeom(const mjModel* m, const mjData* d, int g, Box* box) {
  const double* xpos = d->geom_xpos + 3 * g;
  const double* R = d->geom_xmat + 9 * g;
  const double* s = m->geom_size + 3 * g;
  switch (m->geom_type[g]) {
    case mjGEOM_SPHERE: {
      double half[3] = {s[0], s[0], s[0]};
      box->AddCentered(xpos, half);
      break;
    }
    case mjGEOM_CAPSULE: {
      double half[3] = {s[0], s[0], s[0]};
      for (double sign : {-1.0, 1.0}) {
        double local[3] = {0, 0, sign * s[1]}, c[3];
        Xform(xpos, R, local, c);
        box->AddCentered(c, half);
      }
      break;
    }
    case mjGEOM_CYLINDER: {
      double half[3];
      for (int i = 0; i < 3; ++i) {
        double a = R[3 * i + 2];  // axis component
        half[i] = std::fabs(a) * s[1] + s[0] * std::sqrt(std::max(0.0, 1 - a * a));
      }
      box->AddCentered(xpos, half);
      break;
    }
    case mjGEOM_ELLIPSOID: {
      double half[3];
      for (int i = 0; i < 3; ++i) {
        double sum = 0;
        for (int j = 0; j < 3; ++j) sum += (R[3 * i + j] * s[j]) * (R[3 * i + j] * s[j]);
        half[i] = std::sqrt(sum);
      }
      box->AddCentered(xpos, half);
      break;
    }
    case mjGEOM_BOX: {
      double half[3] = {s[0], s[1], s[2]};
      AddCorners(xpos, R, half, -s[2], s[2], box);
      break;
    }
    case mjGEOM_PLANE: {
      double half[3] = {s[0], s[1], 0};
      AddCorners(xpos, R, half, 0, 0, box);
      break;
    }
    case mjGEOM_HFIELD: {
      int h = m->geom_dataid[g];
      const double* hs = m->hfield_size + 4 * h;
      double half[3] = {hs[0], hs[1], 0};
      AddCorners(xpos, R, half, -hs[3], hs[2], box);
      break;
    }
    case mjGEOM_MESH: {
      int mesh = m->geom_dataid[g];
      int adr = m->mesh_vertadr[mesh], n = m->mesh_vertnum[mesh];
      const float* v = m->mesh_vert + 3 * adr;
      for (int k = 0; k < n; ++k) {
        double local[3] = {v[3 * k], v[3 * k + 1], v[3 * k + 2]}, w[3];
        Xform(xpos, R, local, w);
        box->Add(w);
      }
      break;
    }
    default:
      break;
  }
}

}  // namespace

bool BodyGeomBox(const mjModel* m, const mjData* d, int body, std::array<double, 3>* lo,
                 std::array<double, 3>* hi) {
  Box box;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] == body) AddGeom(m, d, g, &box);
  }
  if (box.empty) return false;
  for (int i = 0; i < 3; ++i) {
    (*lo)[i] = box.lo[i];
    (*hi)[i] = box.hi[i];
  }
  return true;
}

AssetFacts ComputeAssetFacts(const mjModel* m, const std::filesystem::path& path_for_errors) {
  if (m->nbody != 2) {
    throw Error("expected a single body in the asset (other than worldbody), found " +
                    std::to_string(m->nbody - 1),
                path_for_errors.string());
  }
  DataPtr d = MakeData(m);
  mj_kinematics(m, d.get());
  AssetFacts f;
  f.mass = m->body_mass[1];
  Box box;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] >= 1) AddGeom(m, d.get(), g, &box);
  }
  if (!box.empty) {
    const double* origin = d->xpos + 3;
    for (int i = 0; i < 3; ++i) {
      f.aabb_min[i] = box.lo[i] - origin[i];
      f.aabb_max[i] = box.hi[i] - origin[i];
      f.bounding_box[i] = 2 * std::max(std::fabs(f.aabb_min[i]), std::fabs(f.aabb_max[i]));
    }
  }
  return f;
}

AssetFacts ComputeAssetFacts(const std::filesystem::path& xml, bool physics_only) {
  ComposeOptions options;
  options.physics_only = physics_only;
  // physics_only: the composer drops textures, materials, skins and lights, whose decoding
  // costs more than the rest of a textured asset's compile; masses, inertias and geometry
  // equal a full compile's (tests/sim/physics_only_test.cc checks it bitwise).
  MjcfComposer composer(xml, options);
  const std::filesystem::path abs = std::filesystem::absolute(xml).lexically_normal();
  ModelPtr m = composer.Compile();
  return ComputeAssetFacts(m.get(), abs);
}

}  // namespace mlspaces::sim
