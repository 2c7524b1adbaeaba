#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>

#include "shadow_pass_gl.h"

namespace mlspaces::sim::detail {

// The shader: MuJoCo's fixed-function lighting (OpenGL 2.1, section 2.14.1: colour material
// for ambient and diffuse, local viewer, one side, clamped per vertex) and texture modulation,
// with each shadow light's term kept apart and multiplied by its map's test, as MuJoCo's
// per-light passes add it (alpha test 0.99 included).
const char* const kVaryings = R"(
varying vec4 v_base;
#if NMAP > 0
varying vec3 v_l0;
varying vec4 v_m0;
#endif
#if NMAP > 1
varying vec3 v_l1;
varying vec4 v_m1;
#endif
#if NMAP > 2
varying vec3 v_l2;
varying vec4 v_m2;
#endif
#if NMAP > 3
varying vec3 v_l3;
varying vec4 v_m3;
#endif
#if TEXMODE > 0
varying vec3 v_tc;
#endif
)";

const char* const kVertexShader = R"(
uniform vec4 u_lpos[8];
uniform vec3 u_lspotdir[8];
uniform vec3 u_lspot[8];   // cos(cutoff), exponent, 1 for a spot light
uniform vec3 u_latt[8];
uniform vec3 u_lamb[8];
uniform vec3 u_ldif[8];
uniform vec3 u_lspec[8];
uniform int u_lslot[8];    // shadow map of the light, -1 for none
uniform vec3 u_global;
uniform vec4 u_rgba;
uniform float u_emission;
uniform float u_specular;
uniform float u_shininess;
uniform vec4 u_plane_s;
uniform vec4 u_plane_t;
uniform vec4 u_plane_r;
uniform mat4 u_eye_to_map[4];
void main() {
  vec4 eye = gl_ModelViewMatrix * gl_Vertex;
  gl_Position = ftransform();
  gl_ClipVertex = eye;  // the reflection's clip plane
  vec3 p = eye.xyz / eye.w;
  vec3 n = normalize(gl_NormalMatrix * gl_Normal);
  vec3 v = normalize(-p);
  vec3 base = u_emission * u_rgba.rgb + u_global * u_rgba.rgb;
  vec3 sl[4];
  sl[0] = vec3(0.0); sl[1] = vec3(0.0); sl[2] = vec3(0.0); sl[3] = vec3(0.0);
  for (int i = 0; i < NLIGHT; ++i) {
    vec3 l;
    float att = 1.0;
    if (u_lpos[i].w == 0.0) {
      l = normalize(u_lpos[i].xyz);
    } else {
      vec3 d = u_lpos[i].xyz - p;
      float dist = length(d);
      l = d / dist;
      att = 1.0 / (u_latt[i].x + u_latt[i].y * dist + u_latt[i].z * dist * dist);
      if (u_lspot[i].z > 0.5) {
        float c = dot(-l, normalize(u_lspotdir[i]));
        att *= c >= u_lspot[i].x ? pow(max(c, 0.0), u_lspot[i].y) : 0.0;
      }
    }
    vec3 c = u_lamb[i] * u_rgba.rgb;
    float ndl = dot(n, l);
    if (ndl > 0.0) {
      c += ndl * u_ldif[i] * u_rgba.rgb;
      float ndh = max(dot(n, normalize(l + v)), 1e-30);
      c += pow(ndh, u_shininess) * u_specular * u_lspec[i];
    }
    c *= att;
    if (u_lslot[i] < 0) base += c; else sl[u_lslot[i]] = c;
  }
  v_base = vec4(clamp(base, 0.0, 1.0), u_rgba.a);
#if NMAP > 0
  v_l0 = clamp(sl[0], 0.0, 1.0);
  v_m0 = u_eye_to_map[0] * eye;
#endif
#if NMAP > 1
  v_l1 = clamp(sl[1], 0.0, 1.0);
  v_m1 = u_eye_to_map[1] * eye;
#endif
#if NMAP > 2
  v_l2 = clamp(sl[2], 0.0, 1.0);
  v_m2 = u_eye_to_map[2] * eye;
#endif
#if NMAP > 3
  v_l3 = clamp(sl[3], 0.0, 1.0);
  v_m3 = u_eye_to_map[3] * eye;
#endif
#if TEXMODE == 1
  v_tc = vec3(gl_MultiTexCoord0.xy, 0.0);
#elif TEXMODE > 1
  v_tc = vec3(dot(u_plane_s, gl_Vertex), dot(u_plane_t, gl_Vertex), dot(u_plane_r, gl_Vertex));
#endif
}
)";

const char* const kFragmentShader = R"(
uniform sampler2D u_tex2d;
uniform samplerCube u_texcube;
uniform sampler2DShadow u_map0;
uniform sampler2DShadow u_map1;
uniform sampler2DShadow u_map2;
uniform sampler2DShadow u_map3;
uniform vec2 u_alpha;  // the alpha written: alpha * x + y (the lit pass: a tracked geom's id)
vec3 term(vec3 light, float lit, vec4 tex, float alpha) {
  return lit * alpha >= 0.99 ? light * tex.rgb : vec3(0.0);
}
void main() {
#if TEXMODE == 1 || TEXMODE == 2
  vec4 tex = texture2D(u_tex2d, v_tc.xy);
#elif TEXMODE == 3
  vec4 tex = textureCube(u_texcube, v_tc);
#else
  vec4 tex = vec4(1.0);
#endif
  float alpha = v_base.a * tex.a;
  vec3 sum = vec3(0.0);
#if NMAP > 0
  sum += term(v_l0, shadow2DProj(u_map0, v_m0).r, tex, alpha);
#endif
#if NMAP > 1
  sum += term(v_l1, shadow2DProj(u_map1, v_m1).r, tex, alpha);
#endif
#if NMAP > 2
  sum += term(v_l2, shadow2DProj(u_map2, v_m2).r, tex, alpha);
#endif
#if NMAP > 3
  sum += term(v_l3, shadow2DProj(u_map3, v_m3).r, tex, alpha);
#endif
  gl_FragColor = vec4(clamp(v_base.rgb * tex.rgb + sum, 0.0, 1.0), alpha * u_alpha.x + u_alpha.y);
}
)";

bool Supported(const mjvLight& l) {
  return l.type == mjLIGHT_DIRECTIONAL || l.type == mjLIGHT_SPOT;
}

bool Behind(const float* head, const mjvGeom& g) {
  return (head[0] - g.pos[0]) * g.mat[2] + (head[1] - g.pos[1]) * g.mat[5] +
             (head[2] - g.pos[2]) * g.mat[8] <
         0.0f;
}

void HeadPos(const mjvScene& scn, float head[3]) {
  mjtNum h[3];
  mjv_cameraInModel(h, nullptr, nullptr, &scn);
  for (int k = 0; k < 3; ++k) head[k] = static_cast<float>(h[k]);
}

void LoadReversedDepth(const ShadowPass::Gl& gl, bool zero_to_one) {
  gl.MatrixMode(GL_PROJECTION);
  gl.LoadIdentity();
  if (zero_to_one) {
    gl.Translatef(0, 0, 0.5f);
    gl.Scalef(1, 1, -0.5f);
  } else {
    gl.Scalef(1, 1, -1);
  }
}

// Column-major 4x4 product a*b.
std::array<float, 16> Mul(const float* a, const float* b) {
  std::array<float, 16> r{};
  for (int c = 0; c < 4; ++c) {
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += static_cast<double>(a[k * 4 + row]) * b[c * 4 + k];
      r[c * 4 + row] = static_cast<float>(s);
    }
  }
  return r;
}

// Inverse of a rigid column-major transform (rotation and translation).
std::array<float, 16> InverseRigid(const float* m) {
  std::array<float, 16> r{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[j * 4 + i] = m[i * 4 + j];
  }
  for (int i = 0; i < 3; ++i) {
    double s = 0;
    for (int k = 0; k < 3; ++k) s += static_cast<double>(m[i * 4 + k]) * m[12 + k];
    r[12 + i] = static_cast<float>(-s);
  }
  r[15] = 1;
  return r;
}

// mjr_orthoVec and mjr_lookAt (MuJoCo's render_util.c, not exported), as the maps must be
// MuJoCo's: same light frame, same matrix.
void Normalize3(float* v) {
  const float n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (n > mjMINVAL) {
    for (int k = 0; k < 3; ++k) v[k] /= n;
  }
}
void Cross3(float* r, const float* a, const float* b) {
  r[0] = a[1] * b[2] - a[2] * b[1];
  r[1] = a[2] * b[0] - a[0] * b[2];
  r[2] = a[0] * b[1] - a[1] * b[0];
}
void OrthoVec(float* res, const float* v) {
  float other[3] = {-1, 0, 0};
  Cross3(res, v, other);
  if (res[0] * res[0] + res[1] * res[1] + res[2] * res[2] > 0.01f) {
    Normalize3(res);
    return;
  }
  other[0] = 0;
  other[1] = 1;
  Cross3(res, v, other);
  Normalize3(res);
}
std::array<float, 16> LookAtMatrix(const float* eye, const float* forward, const float* up) {
  float f[3] = {forward[0], forward[1], forward[2]}, s[3], u[3];
  Normalize3(f);
  Cross3(s, f, up);
  Normalize3(s);
  Cross3(u, s, f);
  Normalize3(u);
  return {s[0],
          u[0],
          -f[0],
          0,
          s[1],
          u[1],
          -f[1],
          0,
          s[2],
          u[2],
          -f[2],
          0,
          -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]),
          -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]),
          f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2],
          1};
}

float BoundingRadius(const mjvGeom& g) {
  const float* s = g.size;
  switch (g.type) {
    case mjGEOM_SPHERE:
      return s[0];
    case mjGEOM_ELLIPSOID:
      return std::max({s[0], s[1], s[2]});
    case mjGEOM_CAPSULE:
      return std::max(s[0], s[1]) + s[2];
    case mjGEOM_CYLINDER:
      return std::sqrt(std::max(s[0], s[1]) * std::max(s[0], s[1]) + s[2] * s[2]);
    case mjGEOM_BOX:
      return std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    default:
      return -1;
  }
}

float DrawnRadius(const mjvGeom& g, const std::vector<float>& mesh_radius) {
  if (g.type == mjGEOM_MESH || g.type == mjGEOM_SDF) {
    // MuJoCo's display lists: 2 * mesh id, + 1 for the convex hull (a subset of the vertices).
    const size_t mesh = static_cast<size_t>(g.dataid / 2);
    return g.dataid >= 0 && mesh < mesh_radius.size() ? mesh_radius[mesh] : -1.0f;
  }
  return BoundingRadius(g);
}

namespace {
// A bounding radius with the margin that covers float rounding in the view volume's planes
// and in the GL's own transform.
float WithMargin(float radius) { return radius * 1.01f + 1e-3f; }
}  // namespace

bool WithinDepth(const ViewVolume& f, const float* center, float radius) {
  if (radius < 0) return false;
  const float r = WithMargin(radius);
  for (int k = 4; k < 6; ++k) {
    const auto& p = f[k];
    if (p[0] * center[0] + p[1] * center[1] + p[2] * center[2] + p[3] < r) return false;
  }
  return true;
}

ViewVolume ViewVolumeOf(const float* c) {
  // Gribb and Hartmann: the rows of the clip matrix, w +- x, w +- y, w +- z.
  ViewVolume f{};
  for (int k = 0; k < 6; ++k) {
    const int axis = k / 2;
    const float sign = k % 2 == 0 ? 1.0f : -1.0f;
    double n = 0;
    for (int i = 0; i < 4; ++i) {
      f[k][i] = c[i * 4 + 3] + sign * c[i * 4 + axis];
      if (i < 3) n += static_cast<double>(f[k][i]) * f[k][i];
    }
    const float len = static_cast<float>(std::sqrt(n));
    if (len > 0) {
      for (float& v : f[k]) v /= len;
    }
  }
  return f;
}

bool Outside(const ViewVolume& f, const float* center, float radius) {
  if (radius < 0) return false;
  const float r = WithMargin(radius);
  for (const auto& p : f) {
    if (p[0] == 0 && p[1] == 0 && p[2] == 0) continue;  // a degenerate plane culls nothing
    if (p[0] * center[0] + p[1] * center[1] + p[2] * center[2] + p[3] < -r) return true;
  }
  return false;
}

float Rbound(const mjvGeom& g) {
  if (g.objtype == mjOBJ_GEOM) return g.modelrbound;
  const float* s = g.size;
  switch (g.type) {
    case mjGEOM_SPHERE:
      return s[0];
    case mjGEOM_CAPSULE:
      return s[0] + s[2];
    case mjGEOM_CYLINDER:
      return std::sqrt(s[0] * s[0] + s[2] * s[2]);
    case mjGEOM_BOX:
      return std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    default:
      return std::max(s[0], std::max(s[1], s[2]));
  }
}

bool DrawnType(int type) {
  switch (type) {
    case mjGEOM_PLANE:
    case mjGEOM_HFIELD:
    case mjGEOM_SPHERE:
    case mjGEOM_CAPSULE:
    case mjGEOM_ELLIPSOID:
    case mjGEOM_CYLINDER:
    case mjGEOM_BOX:
    case mjGEOM_MESH:
    case mjGEOM_SDF:
      return true;
    default:
      return false;
  }
}

CoarseSides MakeCoarseSides(const ShadowPass::Gl& gl, const mjModel* m) {
  CoarseSides coarse;
  coarse.numquads = m->vis.quality.numquads;
  coarse.numstacks = m->vis.quality.numstacks;
  std::vector<float> vertices;
  for (int pieces = 1; pieces < m->vis.quality.numstacks; pieces *= 2) {
    // numstacks gives the disks their rings (numstacks / 2); only the three straight-sided
    // shapes go into the buffer.
    const BuiltinShapes s =
        MakeBuiltinShapes(m->vis.quality.numslices, std::max(2, pieces), pieces, pieces);
    CoarseLevel level;
    level.pieces = pieces;
    for (const BuiltinShape k : {kShapeCylinder, kShapeCylinderOpen, kShapeBox}) {
      const BuiltinShapes::Range r = s.ranges[k];
      level.ranges[k] = {static_cast<int>(vertices.size() / 6), r.count};
      vertices.insert(vertices.end(), s.vertices.begin() + 6 * static_cast<ptrdiff_t>(r.first),
                      s.vertices.begin() + 6 * static_cast<ptrdiff_t>(r.first + r.count));
    }
    coarse.levels.push_back(level);
  }
  gl.GenBuffers(1, &coarse.buffer);
  gl.BindBuffer(GL_ARRAY_BUFFER, coarse.buffer);
  gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)),
                vertices.data(), GL_STATIC_DRAW);
  gl.BindBuffer(GL_ARRAY_BUFFER, 0);
  for (CoarseLevel& level : coarse.levels) level.buffer = coarse.buffer;
  return coarse;
}

const CoarseLevel* CoarseLevelFor(const CoarseSides& coarse, const mjvGeom& g, const float* eye,
                                  const float* points, int npoint) {
  float side = 0;  // the longest straight piece the shape has, uncut
  int mujoco_pieces = 0;
  switch (g.type) {
    case mjGEOM_CYLINDER:  // side and disks (a ring is a side's stack at half the count)
      side = 2 * std::max(g.size[2], g.size[0]);
      mujoco_pieces = coarse.numstacks;
      break;
    case mjGEOM_CAPSULE:  // side only: the caps are MuJoCo's
      side = 2 * g.size[2];
      mujoco_pieces = coarse.numstacks;
      break;
    case mjGEOM_BOX:
      side = 2 * std::max(g.size[0], std::max(g.size[1], g.size[2]));
      mujoco_pieces = coarse.numquads;
      break;
    default:
      return nullptr;
  }
  const float radius = BoundingRadius(g);
  auto nearest = [&](const float* p) {
    const float d =
        std::sqrt((p[0] - g.pos[0]) * (p[0] - g.pos[0]) + (p[1] - g.pos[1]) * (p[1] - g.pos[1]) +
                  (p[2] - g.pos[2]) * (p[2] - g.pos[2]));
    return d - radius;
  };
  float distance = nearest(eye);
  for (int i = 0; i < npoint; ++i) distance = std::min(distance, nearest(points + 3 * i));
  if (!(distance > 0)) return nullptr;
  const float needed = side / (distance * kCoarsePieceAngle);
  for (const CoarseLevel& level : coarse.levels) {
    if (level.pieces >= mujoco_pieces) return nullptr;
    if (static_cast<float>(level.pieces) >= needed) return &level;
  }
  return nullptr;
}

// renderGeom's transform and display lists, for the types DrawnType() accepts (a plane is
// never seen from behind here: Unsupported() leaves those scenes to mjr_render).
void DrawGeom(const ShadowPass::Gl& gl, const mjvGeom& g, const mjrContext& con,
              const CoarseLevel* coarse) {
  auto draw = [&](BuiltinShape which) {
    if (coarse != nullptr && coarse->ranges[which].count > 0) {
      const BuiltinShapes::Range r = coarse->ranges[which];
      gl.BindBuffer(GL_ARRAY_BUFFER, coarse->buffer);
      gl.EnableClientState(GL_VERTEX_ARRAY);
      gl.EnableClientState(GL_NORMAL_ARRAY);
      gl.VertexPointer(3, GL_FLOAT, 6 * sizeof(float), nullptr);
      gl.NormalPointer(GL_FLOAT, 6 * sizeof(float),
                       reinterpret_cast<const void*>(3 * sizeof(float)));  // NOLINT
      gl.DrawArrays(GL_TRIANGLES, r.first, r.count);
      gl.DisableClientState(GL_NORMAL_ARRAY);
      gl.DisableClientState(GL_VERTEX_ARRAY);
      gl.BindBuffer(GL_ARRAY_BUFFER, 0);
      return;
    }
    gl.CallList(con.baseBuiltin + which);
  };
  const float* size = g.size;
  const float mat[16] = {g.mat[0], g.mat[3], g.mat[6], 0, g.mat[1], g.mat[4], g.mat[7], 0,
                         g.mat[2], g.mat[5], g.mat[8], 0, 0,        0,        0,        1};
  gl.PushMatrix();
  gl.Translatef(g.pos[0], g.pos[1], g.pos[2]);
  gl.MultMatrixf(mat);
  switch (g.type) {
    case mjGEOM_PLANE:
      if (g.dataid >= 0) {
        gl.CallList(con.basePlane + g.dataid + 1);
      } else {
        gl.Scalef(size[0], size[1], 1.0f);
        gl.CallList(con.basePlane);
      }
      break;
    case mjGEOM_HFIELD:
      if (g.dataid >= 0) gl.CallList(con.baseHField + g.dataid);
      break;
    case mjGEOM_SPHERE:
    case mjGEOM_ELLIPSOID:
      gl.Scalef(size[0], size[1], size[2]);
      draw(kShapeSphere);
      break;
    case mjGEOM_CAPSULE: {
      const float av = 0.5f * (size[0] + size[1]);
      gl.Scalef(size[0], size[1], size[2]);
      draw(kShapeCylinderOpen);
      gl.Scalef(1, 1, av / size[2]);
      gl.Translatef(0, 0, (size[2] - av) / av);
      draw(kShapeSphereTop);
      gl.Translatef(0, 0, 2 * (av - size[2]) / av);
      draw(kShapeSphereBottom);
      break;
    }
    case mjGEOM_CYLINDER:
      gl.Scalef(size[0], size[1], size[2]);
      draw(kShapeCylinder);
      break;
    case mjGEOM_BOX:
      gl.Scalef(size[0], size[1], size[2]);
      draw(kShapeBox);
      break;
    case mjGEOM_MESH:
    case mjGEOM_SDF:
      if (g.dataid >= 0) gl.CallList(con.baseMesh + g.dataid);
      break;
    default:
      break;
  }
  gl.PopMatrix();
}

bool MeshClosed(const mjModel* m, int mesh) {
  const int* face = m->mesh_face + 3 * static_cast<size_t>(m->mesh_faceadr[mesh]);
  const float* vert = m->mesh_vert + 3 * static_cast<size_t>(m->mesh_vertadr[mesh]);
  const int nface = m->mesh_facenum[mesh];
  if (nface < 4) return false;
  // The directed edges, a key each (from << 32 | to), sorted: a repeat is an edge shared the
  // same way round (an inconsistent orientation or more than two faces), a missing reverse a
  // border.
  std::vector<uint64_t> edges;
  edges.reserve(3 * static_cast<size_t>(nface));
  double volume = 0;  // six times the signed volume
  for (int f = 0; f < nface; ++f) {
    const int* v = face + 3 * static_cast<size_t>(f);
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) return false;
    for (int e = 0; e < 3; ++e) {
      edges.push_back(static_cast<uint64_t>(v[e]) << 32 | static_cast<uint32_t>(v[(e + 1) % 3]));
    }
    const float* a = vert + 3 * static_cast<size_t>(v[0]);
    const float* b = vert + 3 * static_cast<size_t>(v[1]);
    const float* c = vert + 3 * static_cast<size_t>(v[2]);
    volume += static_cast<double>(a[0]) *
                  (static_cast<double>(b[1]) * c[2] - static_cast<double>(b[2]) * c[1]) +
              static_cast<double>(a[1]) *
                  (static_cast<double>(b[2]) * c[0] - static_cast<double>(b[0]) * c[2]) +
              static_cast<double>(a[2]) *
                  (static_cast<double>(b[0]) * c[1] - static_cast<double>(b[1]) * c[0]);
  }
  std::sort(edges.begin(), edges.end());
  if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return false;
  for (const uint64_t e : edges) {
    const uint64_t reverse = e << 32 | e >> 32;
    if (!std::binary_search(edges.begin(), edges.end(), reverse)) return false;
  }
  return volume > 0;
}

IndexedShapes IndexShapes(const BuiltinShapes& shapes) {
  IndexedShapes out;
  for (int k = 0; k < kShapeCount; ++k) {
    const BuiltinShapes::Range r = shapes.ranges[k];
    IndexedShapes::Range& o = out.ranges[k];
    o.first_vertex = static_cast<int>(out.positions.size() / 3);
    o.first_index = static_cast<int>(out.indices.size());
    std::map<std::array<float, 3>, unsigned int> seen;
    for (int v = r.first; v < r.first + r.count; ++v) {
      std::array<float, 3> p;
      std::copy_n(&shapes.vertices[6 * static_cast<size_t>(v)], 3, p.begin());
      const auto [it, added] = seen.emplace(p, static_cast<unsigned int>(seen.size()));
      if (added) out.positions.insert(out.positions.end(), p.begin(), p.end());
      out.indices.push_back(it->second);
    }
    o.vertex_count = static_cast<int>(seen.size());
    o.index_count = r.count;
  }
  return out;
}

bool AppendWorldShape(const IndexedShapes& shapes, const mjvGeom& g, std::vector<float>* positions,
                      std::vector<unsigned int>* indices) {
  const float* size = g.size;
  // One shape: its unit vertices v placed at pos + mat * (scale .* v + shift).
  auto add = [&](BuiltinShape which, const float scale[3], const float shift[3]) {
    const IndexedShapes::Range r = shapes.ranges[which];
    const auto base = static_cast<unsigned int>(positions->size() / 3);
    for (int v = r.first_vertex; v < r.first_vertex + r.vertex_count; ++v) {
      const float* p = &shapes.positions[3 * static_cast<size_t>(v)];
      float local[3];
      for (int i = 0; i < 3; ++i) local[i] = scale[i] * p[i] + shift[i];
      for (int i = 0; i < 3; ++i) {
        positions->push_back(g.pos[i] + g.mat[3 * i] * local[0] + g.mat[3 * i + 1] * local[1] +
                             g.mat[3 * i + 2] * local[2]);
      }
    }
    for (int i = r.first_index; i < r.first_index + r.index_count; ++i) {
      indices->push_back(base + shapes.indices[static_cast<size_t>(i)]);
    }
  };
  const float none[3] = {0, 0, 0};
  switch (g.type) {
    case mjGEOM_SPHERE:
    case mjGEOM_ELLIPSOID:
      add(kShapeSphere, size, none);
      return true;
    case mjGEOM_CYLINDER:
      add(kShapeCylinder, size, none);
      return true;
    case mjGEOM_BOX:
      add(kShapeBox, size, none);
      return true;
    case mjGEOM_CAPSULE: {
      // renderGeom's end caps: unit half spheres centred at z = +-1, scaled by the mean
      // radius along z and moved to the cylinder's ends.
      const float av = 0.5f * (size[0] + size[1]);
      const float cap[3] = {size[0], size[1], av};
      const float top[3] = {0, 0, size[2] - av}, bottom[3] = {0, 0, av - size[2]};
      add(kShapeCylinderOpen, size, none);
      add(kShapeSphereTop, cap, top);
      add(kShapeSphereBottom, cap, bottom);
      return true;
    }
    default:
      return false;
  }
}

// settexture's choice for a geom (MuJoCo 3.5.0's render_gl3.c): mode (as the shader's
// TEXMODE), GL texture and object planes.

GeomTexture TextureOf(const mjvGeom& g, const mjrContext& con) {
  GeomTexture out;
  if (g.matid < 0) return out;
  const int texid = con.mat_texid[mjNTEXROLE * g.matid + mjTEXROLE_RGB];
  const bool uniform = con.mat_texuniform[g.matid] != 0;
  if (g.texcoord) {
    if (texid < 0) return out;
    out.mode = 1;
    out.texture = con.texture[texid];
  } else if (texid >= 0 && con.textureType[texid] == mjTEXTURE_2D) {
    float scl[2] = {con.mat_texrepeat[g.matid * 2], con.mat_texrepeat[g.matid * 2 + 1]};
    if (g.dataid >= 0) {
      if (g.size[0] > 0) scl[0] = scl[0] / std::max<float>(mjMINVAL, g.size[0]);
      if (g.size[1] > 0) scl[1] = scl[1] / std::max<float>(mjMINVAL, g.size[1]);
    }
    if (uniform) {
      if (g.size[0] > 0) scl[0] = scl[0] * g.size[0];
      if (g.size[1] > 0) scl[1] = scl[1] * g.size[1];
    }
    out.mode = 2;
    out.texture = con.texture[texid];
    const float s[4] = {0.5f * scl[0], 0, 0, -0.5f}, t[4] = {0, -0.5f * scl[1], 0, -0.5f};
    std::memcpy(out.s, s, sizeof s);
    std::memcpy(out.t, t, sizeof t);
  } else if (texid >= 0) {
    out.mode = 3;
    out.texture = con.texture[texid];
    out.s[0] = uniform ? g.size[0] : 1;
    out.t[1] = uniform ? g.size[1] : 1;
    out.r[2] = uniform ? g.size[2] : 1;
  }
  return out;
}

}  // namespace mlspaces::sim::detail
