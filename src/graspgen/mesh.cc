// Collision geometry extraction, validation and surface sampling
// (include/mlspaces/graspgen/mesh.h).
#include "mlspaces/graspgen/mesh.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::graspgen {
namespace {

double FaceArea(const TriMesh& m, size_t f) {
  const auto& t = m.faces[f];
  return 0.5 * Norm(Cross(Sub(m.vertices[t[1]], m.vertices[t[0]]),
                          Sub(m.vertices[t[2]], m.vertices[t[0]])));
}

// Appends a unit-shape mesh to `out`, mapping each vertex through `map`.
template <class Map>
void Append(TriMesh& out, const std::vector<Vec3>& verts,
            const std::vector<std::array<int32_t, 3>>& faces, Map&& map) {
  const auto base = static_cast<int32_t>(out.vertices.size());
  for (const Vec3& v : verts) out.vertices.push_back(map(v));
  for (const auto& f : faces) out.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
}

// Surface of revolution about z: rings of (radius, z) from bottom to top, `seg` segments; the
// first and last ring may have radius 0 (poles). Faces wind outward.
void Revolve(const std::vector<std::array<double, 2>>& rings, int seg, std::vector<Vec3>& v,
             std::vector<std::array<int32_t, 3>>& f) {
  std::vector<int32_t> start;
  for (const auto& [r, z] : rings) {
    start.push_back(static_cast<int32_t>(v.size()));
    if (r == 0) {
      v.push_back({0, 0, z});
      continue;
    }
    for (int k = 0; k < seg; ++k) {
      const double a = 2 * std::numbers::pi * k / seg;
      v.push_back({r * std::cos(a), r * std::sin(a), z});
    }
  }
  auto idx = [&](size_t ring, int k) {
    return rings[ring][0] == 0 ? start[ring] : start[ring] + (k % seg);
  };
  for (size_t i = 0; i + 1 < rings.size(); ++i) {
    for (int k = 0; k < seg; ++k) {
      const int32_t a = idx(i, k), b = idx(i, k + 1), c = idx(i + 1, k), d = idx(i + 1, k + 1);
      if (a != b) f.push_back({a, b, d});
      if (c != d) f.push_back({a, d, c});
    }
  }
}

// A closed cylinder / capsule / sphere profile: bottom pole, rings, top pole.
void Primitive(int type, const double* size, std::vector<Vec3>& v,
               std::vector<std::array<int32_t, 3>>& f) {
  constexpr int kSeg = 24;
  constexpr int kHemi = 6;  // rings per hemisphere
  std::vector<std::array<double, 2>> rings;
  if (type == mjGEOM_BOX) {
    const double x = size[0], y = size[1], z = size[2];
    v = {{-x, -y, -z}, {x, -y, -z}, {x, y, -z}, {-x, y, -z},
         {-x, -y, z},  {x, -y, z},  {x, y, z},  {-x, y, z}};
    f = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
         {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
    return;
  }
  if (type == mjGEOM_CYLINDER) {
    rings = {{0, -size[1]}, {size[0], -size[1]}, {size[0], size[1]}, {0, size[1]}};
  } else {  // sphere / ellipsoid (unit sphere, scaled by the caller) / capsule
    const double r = type == mjGEOM_CAPSULE ? size[0] : 1.0;
    const double h = type == mjGEOM_CAPSULE ? size[1] : 0.0;
    for (int i = 0; i <= kHemi; ++i) {  // bottom hemisphere, from the pole
      const double a = -std::numbers::pi / 2 + std::numbers::pi / 2 * i / kHemi;
      rings.push_back({i == 0 ? 0.0 : r * std::cos(a), -h + r * std::sin(a)});
    }
    for (int i = 0; i <= kHemi; ++i) {  // top hemisphere, to the pole
      const double a = std::numbers::pi / 2 * i / kHemi;
      if (i == 0 && h == 0) continue;  // the equator ring is already there
      rings.push_back({i == kHemi ? 0.0 : r * std::cos(a), h + r * std::sin(a)});
    }
  }
  Revolve(rings, kSeg, v, f);
}

}  // namespace

double TriMesh::Area() const {
  double a = 0;
  for (size_t f = 0; f < faces.size(); ++f) a += FaceArea(*this, f);
  return a;
}

Vec3 FaceNormal(const TriMesh& m, size_t f) {
  const auto& t = m.faces[f];
  Vec3 n = Cross(Sub(m.vertices[t[1]], m.vertices[t[0]]), Sub(m.vertices[t[2]], m.vertices[t[0]]));
  const double len = Norm(n);
  if (!(len > 0)) return {0, 0, 0};
  return {n[0] / len, n[1] / len, n[2] / len};
}

TriMesh ValidatedMesh(TriMesh mesh, const std::string& source) {
  if (mesh.faces.empty()) throw Error("collision mesh has no triangles", source);
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (double c : mesh.vertices[i]) {
      if (!std::isfinite(c)) {
        throw Error("collision mesh vertex " + std::to_string(i) + " is not finite", source);
      }
    }
  }
  const auto nv = static_cast<int64_t>(mesh.vertices.size());
  std::vector<std::array<int32_t, 3>> kept;
  kept.reserve(mesh.faces.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int32_t i : mesh.faces[f]) {
      if (i < 0 || i >= nv) {
        throw Error("collision mesh face " + std::to_string(f) + " has vertex index " +
                        std::to_string(i) + " out of range",
                    source);
      }
    }
    if (FaceArea(mesh, f) >= 1e-12) kept.push_back(mesh.faces[f]);
  }
  if (kept.empty()) throw Error("collision mesh has only degenerate (zero-area) triangles", source);
  mesh.faces = std::move(kept);
  return mesh;
}

TriMesh GeomsMesh(const mjModel* m, const std::vector<int>& geoms, int body,
                  const std::string& source) {
  if (body < 0 || body >= m->nbody) throw Error("no body " + std::to_string(body), source);
  if (geoms.empty()) throw Error("no geoms to mesh", source);
  const sim::DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  mj_kinematics(m, d);
  const Mat4 body_inv = InverseRigid(
      ToMat4(Vec3{d->xpos[3 * body], d->xpos[3 * body + 1], d->xpos[3 * body + 2]}, [&] {
        Rot3 r;
        std::copy_n(d->xmat + 9 * body, 9, r.begin());
        return r;
      }()));
  TriMesh out;
  std::string unsupported;
  for (int g : geoms) {
    if (g < 0 || g >= m->ngeom) throw Error("no geom " + std::to_string(g), source);
    Rot3 r;
    std::copy_n(d->geom_xmat + 9 * g, 9, r.begin());
    const Mat4 t =
        body_inv *
        ToMat4(Vec3{d->geom_xpos[3 * g], d->geom_xpos[3 * g + 1], d->geom_xpos[3 * g + 2]}, r);
    const int type = m->geom_type[g];
    const double* size = m->geom_size + 3 * g;
    Vec3 scale{1, 1, 1};
    std::vector<Vec3> verts;
    std::vector<std::array<int32_t, 3>> faces;
    if (type == mjGEOM_MESH) {
      const int id = m->geom_dataid[g];
      const int va = m->mesh_vertadr[id], vn = m->mesh_vertnum[id];
      const int fa = m->mesh_faceadr[id], fn = m->mesh_facenum[id];
      for (int i = 0; i < vn; ++i) {
        const float* p = m->mesh_vert + 3 * (va + i);
        verts.push_back({p[0], p[1], p[2]});
      }
      for (int i = 0; i < fn; ++i) {
        const int* p = m->mesh_face + 3 * (fa + i);
        faces.push_back({p[0], p[1], p[2]});
      }
    } else if (type == mjGEOM_BOX || type == mjGEOM_CYLINDER || type == mjGEOM_CAPSULE ||
               type == mjGEOM_SPHERE) {
      Primitive(type, size, verts, faces);
      if (type == mjGEOM_SPHERE) scale = {size[0], size[0], size[0]};
    } else if (type == mjGEOM_ELLIPSOID) {
      Primitive(mjGEOM_SPHERE, size, verts, faces);
      scale = {size[0], size[1], size[2]};
    } else {
      const char* name = mj_id2name(m, mjOBJ_GEOM, g);
      throw Error("geom " + (name ? std::string(name) : "#" + std::to_string(g)) +
                      ": unsupported collision geom type " + std::to_string(type) +
                      " (plane, height field or SDF)",
                  source);
    }
    Append(out, verts, faces, [&](const Vec3& v) {
      const Vec3 s{v[0] * scale[0], v[1] * scale[1], v[2] * scale[2]};
      return Vec3{t(0, 0) * s[0] + t(0, 1) * s[1] + t(0, 2) * s[2] + t(0, 3),
                  t(1, 0) * s[0] + t(1, 1) * s[1] + t(1, 2) * s[2] + t(1, 3),
                  t(2, 0) * s[0] + t(2, 1) * s[1] + t(2, 2) * s[2] + t(2, 3)};
    });
  }
  return ValidatedMesh(std::move(out), source);
}

TriMesh CollisionMesh(const mjModel* m, int body, const std::string& source) {
  if (body < 0 || body >= m->nbody) throw Error("no body " + std::to_string(body), source);
  const std::vector<int> geoms = sim::CollisionGeoms(m, body);
  if (geoms.empty()) {
    const char* name = mj_id2name(m, mjOBJ_BODY, body);
    throw Error("body " + std::string(name ? name : "#" + std::to_string(body)) +
                    " has no collision geometry (no geom with contype or conaffinity set)",
                source);
  }
  return GeomsMesh(m, geoms, body, source);
}

TriMesh AssetCollisionMesh(const std::filesystem::path& asset_file, const std::string& body) {
  const sim::ModelPtr model = sim::ComposeAndCompile(asset_file);
  int id = -1;
  if (body.empty()) {
    for (int b = 1; b < model->nbody && id < 0; ++b) {
      if (model->body_parentid[b] == 0) id = b;
    }
    if (id < 0) throw Error("the asset has no body", asset_file.string());
  } else {
    id = mj_name2id(model.get(), mjOBJ_BODY, body.c_str());
    if (id < 0) throw Error("no body named '" + body + "'", asset_file.string());
  }
  return CollisionMesh(model.get(), id, asset_file.string());
}

SurfaceSamples SampleSurface(const TriMesh& mesh, double density, uint64_t seed) {
  if (!(density > 0)) throw Error("surface density must be > 0");
  std::vector<double> cdf(mesh.faces.size());
  double total = 0;
  for (size_t f = 0; f < mesh.faces.size(); ++f) cdf[f] = total += FaceArea(mesh, f);
  SurfaceSamples out;
  if (!(total > 0)) return out;
  const auto n = static_cast<size_t>(std::ceil(total / density - 1e-9));
  Rng rng(seed);
  for (size_t i = 0; i < n; ++i) {
    const double x = rng.Uniform01() * total;
    const size_t f =
        std::min<size_t>(std::upper_bound(cdf.begin(), cdf.end(), x) - cdf.begin(), cdf.size() - 1);
    double u = rng.Uniform01(), v = rng.Uniform01();
    if (u + v > 1) u = 1 - u, v = 1 - v;
    const auto& t = mesh.faces[f];
    const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    out.points.push_back({a[0] + u * (b[0] - a[0]) + v * (c[0] - a[0]),
                          a[1] + u * (b[1] - a[1]) + v * (c[1] - a[1]),
                          a[2] + u * (b[2] - a[2]) + v * (c[2] - a[2])});
    out.normals.push_back(FaceNormal(mesh, f));
    out.faces.push_back(static_cast<int32_t>(f));
  }
  return out;
}

}  // namespace mlspaces::graspgen
