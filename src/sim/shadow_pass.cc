#include "shadow_pass.h"

#define GL_GLEXT_PROTOTYPES 1  // declarations only: the functions are loaded at run time
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "builtin_shapes.h"
#include "mlspaces/core/error.h"

namespace mlspaces::sim {

// The GL functions the pass calls, loaded through the context's loader (MuJoCo links its own
// loader privately, and this library links no GL).
#define MLSPACES_SHADOW_PASS_GL(X) \
  X(ActiveTexture)                 \
  X(AttachShader)                  \
  X(BindBuffer)                    \
  X(BindFramebuffer)               \
  X(BufferData)                    \
  X(DeleteBuffers)                 \
  X(DisableClientState)            \
  X(DrawArrays)                    \
  X(EnableClientState)             \
  X(GenBuffers)                    \
  X(NormalPointer)                 \
  X(VertexPointer)                 \
  X(BindTexture)                   \
  X(BlendFunc)                     \
  X(CallList)                      \
  X(CheckFramebufferStatus)        \
  X(Clear)                         \
  X(ColorMask)                     \
  X(CompileShader)                 \
  X(CreateProgram)                 \
  X(CreateShader)                  \
  X(DeleteFramebuffers)            \
  X(DeleteProgram)                 \
  X(DeleteShader)                  \
  X(DeleteTextures)                \
  X(DepthFunc)                     \
  X(DepthMask)                     \
  X(Disable)                       \
  X(DrawBuffer)                    \
  X(Frustum)                       \
  X(Ortho)                         \
  X(TexImage2D)                    \
  X(Enable)                        \
  X(FramebufferTexture2D)          \
  X(GenFramebuffers)               \
  X(GenTextures)                   \
  X(GetFloatv)                     \
  X(GetIntegerv)                   \
  X(GetProgramInfoLog)             \
  X(GetProgramiv)                  \
  X(GetShaderInfoLog)              \
  X(GetShaderiv)                   \
  X(GetUniformLocation)            \
  X(IsEnabled)                     \
  X(LinkProgram)                   \
  X(LoadIdentity)                  \
  X(LoadMatrixf)                   \
  X(MatrixMode)                    \
  X(MultMatrixf)                   \
  X(PolygonOffset)                 \
  X(PopMatrix)                     \
  X(PushMatrix)                    \
  X(ReadBuffer)                    \
  X(Scalef)                        \
  X(ShaderSource)                  \
  X(TexParameteri)                 \
  X(Translatef)                    \
  X(Uniform1f)                     \
  X(Uniform1i)                     \
  X(Uniform1iv)                    \
  X(Uniform3fv)                    \
  X(Uniform4fv)                    \
  X(UniformMatrix4fv)              \
  X(UseProgram)                    \
  X(Viewport)

struct ShadowPass::Gl {
#define MLSPACES_DECLARE(name) decltype(&::gl##name) name = nullptr;
  MLSPACES_SHADOW_PASS_GL(MLSPACES_DECLARE)
#undef MLSPACES_DECLARE
};

namespace {

constexpr int kMaxShadowLights = 4;
constexpr int kMapSlices = 16, kMapStacks = 8;
constexpr int kMaxLights = 8;  // the fixed-function lights mjr_render can use

// Texture units: material textures on 0 (2D) and 1 (cube), the shadow maps from 2.
constexpr int kUnit2d = 0, kUnitCube = 1, kUnitMap0 = 2;

// The shader: MuJoCo's fixed-function lighting (OpenGL 2.1, section 2.14.1: colour material
// for ambient and diffuse, local viewer, one side, clamped per vertex) and texture modulation,
// with each shadow light's term kept apart and multiplied by its map's test, as MuJoCo's
// per-light passes add it (alpha test 0.99 included).
constexpr const char* kVertexShader = R"(
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
uniform int u_texmode;     // 0 none, 1 texture coordinates, 2 2D object planes, 3 cube planes
uniform vec4 u_plane_s;
uniform vec4 u_plane_t;
uniform vec4 u_plane_r;
uniform mat4 u_eye_to_map[4];
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
varying vec3 v_tc;
void main() {
  vec4 eye = gl_ModelViewMatrix * gl_Vertex;
  gl_Position = ftransform();
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
  if (u_texmode == 1) {
    v_tc = vec3(gl_MultiTexCoord0.xy, 0.0);
  } else {
    v_tc = vec3(dot(u_plane_s, gl_Vertex), dot(u_plane_t, gl_Vertex), dot(u_plane_r, gl_Vertex));
  }
}
)";

constexpr const char* kFragmentShader = R"(
uniform int u_texmode;
uniform sampler2D u_tex2d;
uniform samplerCube u_texcube;
uniform sampler2DShadow u_map0;
uniform sampler2DShadow u_map1;
uniform sampler2DShadow u_map2;
uniform sampler2DShadow u_map3;
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
varying vec3 v_tc;
vec3 term(vec3 light, float lit, vec4 tex, float alpha) {
  return lit * alpha >= 0.99 ? light * tex.rgb : vec3(0.0);
}
void main() {
  vec4 tex = vec4(1.0);
  if (u_texmode == 1 || u_texmode == 2) tex = texture2D(u_tex2d, v_tc.xy);
  else if (u_texmode == 3) tex = textureCube(u_texcube, v_tc);
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
  gl_FragColor = vec4(clamp(v_base.rgb * tex.rgb + sum, 0.0, 1.0), alpha);
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

// renderGeom's transform and shapes, for the types DrawnType() accepts (a plane is never seen
// from behind here: Supports() leaves those scenes to mjr_render). The builtin shapes come
// from `shapes` when given (bound as the vertex and normal arrays), else from MuJoCo's
// display lists, as planes, height fields and meshes always do.
void DrawGeom(const ShadowPass::Gl& gl, const mjvGeom& g, const mjrContext& con,
              const BuiltinShapes* shapes) {
  auto draw = [&](BuiltinShape which) {
    if (shapes == nullptr) {
      gl.CallList(con.baseBuiltin + which);
    } else {
      gl.DrawArrays(GL_TRIANGLES, shapes->ranges[which].first, shapes->ranges[which].count);
    }
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

// settexture's choice for a geom (MuJoCo 3.5.0's render_gl3.c): mode (as the shader's
// u_texmode), GL texture and object planes.
struct GeomTexture {
  int mode = 0;
  unsigned int texture = 0;
  float s[4] = {0, 0, 0, 0}, t[4] = {0, 0, 0, 0}, r[4] = {0, 0, 0, 0};
};

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

}  // namespace

ShadowPass::ShadowPass(GlProcLoader load, const mjModel* m)
    : gl_(std::make_unique<Gl>()),
      // The maps' shapes: coarser than MuJoCo's (their vertices are most of a map's cost), an
      // error under a millimetre on a 6 cm capsule, below the maps' texels.
      shapes_(std::make_unique<BuiltinShapes>(
          MakeBuiltinShapes(std::min(m->vis.quality.numslices, kMapSlices),
                            std::min(m->vis.quality.numstacks, kMapStacks), 1))) {
  Gl& gl = *gl_;
#define MLSPACES_LOAD(name)                                            \
  gl.name = reinterpret_cast<decltype(&::gl##name)>(load("gl" #name)); \
  if (gl.name == nullptr) {                                            \
    throw Error("one-pass shadows: the GL library has no gl" #name);   \
  }
  MLSPACES_SHADOW_PASS_GL(MLSPACES_LOAD)
#undef MLSPACES_LOAD
  // The shaders build here once, so that a driver without GLSL 1.20 fails at construction.
  Program(1, 1);
  gl.GenBuffers(1, &shape_buffer_);
  gl.BindBuffer(GL_ARRAY_BUFFER, shape_buffer_);
  gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(shapes_->vertices.size() * sizeof(float)),
                shapes_->vertices.data(), GL_STATIC_DRAW);
  gl.BindBuffer(GL_ARRAY_BUFFER, 0);
}

void ShadowPass::BindShapes(bool on) {
  Gl& gl = *gl_;
  if (on) {
    gl.BindBuffer(GL_ARRAY_BUFFER, shape_buffer_);
    gl.VertexPointer(3, GL_FLOAT, 6 * sizeof(float), nullptr);
    gl.NormalPointer(GL_FLOAT, 6 * sizeof(float), reinterpret_cast<const void*>(3 * sizeof(float)));
    gl.EnableClientState(GL_VERTEX_ARRAY);
    gl.EnableClientState(GL_NORMAL_ARRAY);
  } else {
    gl.DisableClientState(GL_VERTEX_ARRAY);
    gl.DisableClientState(GL_NORMAL_ARRAY);
    gl.BindBuffer(GL_ARRAY_BUFFER, 0);
  }
}

unsigned int ShadowPass::Program(int nlight, int nmap) {
  const int key = nlight * (kMaxShadowLights + 1) + nmap;
  if (auto it = programs_.find(key); it != programs_.end()) return it->second;
  Gl& gl = *gl_;
  const std::string defines = "#version 120\n#define NLIGHT " + std::to_string(nlight) +
                              "\n#define NMAP " + std::to_string(nmap) + "\n";
  auto compile = [&](GLenum kind, const char* body) {
    const std::string text = defines + body;
    const char* source = text.c_str();
    const GLuint sh = gl.CreateShader(kind);
    gl.ShaderSource(sh, 1, &source, nullptr);
    gl.CompileShader(sh);
    GLint ok = 0;
    gl.GetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (!ok) {
      char log[1024] = {0};
      gl.GetShaderInfoLog(sh, sizeof log, nullptr, log);
      gl.DeleteShader(sh);
      std::string line(log);
      for (char& c : line) c = c == '\n' ? ' ' : c;
      throw Error("one-pass shadows: the shader does not compile: " + line);
    }
    return sh;
  };
  const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  } catch (...) {
    gl.DeleteShader(vs);
    throw;
  }
  const GLuint program = gl.CreateProgram();
  gl.AttachShader(program, vs);
  gl.AttachShader(program, fs);
  gl.LinkProgram(program);
  gl.DeleteShader(vs);
  gl.DeleteShader(fs);
  GLint ok = 0;
  gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[1024] = {0};
    gl.GetProgramInfoLog(program, sizeof log, nullptr, log);
    gl.DeleteProgram(program);
    throw Error(std::string("one-pass shadows: the shader does not link: ") + log);
  }
  programs_[key] = program;
  return program;
}

ShadowPass::~ShadowPass() {
  Gl& gl = *gl_;
  if (shape_buffer_) gl.DeleteBuffers(1, &shape_buffer_);
  for (int k = 0; k < kMaxShadowLights; ++k) {
    if (map_fbo_[k]) gl.DeleteFramebuffers(1, &map_fbo_[k]);
    if (map_tex_[k]) gl.DeleteTextures(1, &map_tex_[k]);
  }
  for (const auto& [key, program] : programs_) gl.DeleteProgram(program);
}

bool ShadowPass::Supports(const mjvScene& scn, const mjrContext& con) const {
  if (!scn.flags[mjRND_SHADOW] || !con.shadowFBO || con.shadowSize <= 2) return false;
  if (scn.flags[mjRND_FOG] || scn.flags[mjRND_SEGMENT] || scn.flags[mjRND_WIREFRAME] ||
      scn.flags[mjRND_IDCOLOR] || scn.flags[mjRND_DEPTH]) {
    return false;
  }
  if (scn.stereo != mjSTEREO_NONE || scn.framewidth > 0 || scn.enabletransform) return false;
  if (scn.nlight > kMaxLights || scn.nskin > 0) return false;
  int shadow_lights = 0;
  for (int i = 0; i < scn.nlight; ++i) {
    // MuJoCo 3.5 enables point and image lights with the last position set: left to it.
    if (!Supported(scn.lights[i])) return false;
    shadow_lights += scn.lights[i].castshadow;
  }
  if (shadow_lights == 0 || shadow_lights > kMaxShadowLights) return false;
  float head[3];
  HeadPos(scn, head);
  for (int i = 0; i < scn.ngeom; ++i) {
    const mjvGeom& g = scn.geoms[i];
    if (!DrawnType(g.type) || g.label[0] != '\0') return false;
    if (g.rgba[3] < 0.995f || (g.type == mjGEOM_PLANE && Behind(head, g))) return false;
  }
  return true;
}

void ShadowPass::DrawMaps(const mjvScene& scn, const mjrContext& con,
                          const std::vector<int>& lights) {
  Gl& gl = *gl_;
  if (map_size_ != con.shadowSize) {
    for (int k = 0; k < kMaxShadowLights; ++k) {
      if (map_fbo_[k]) gl.DeleteFramebuffers(1, &map_fbo_[k]);
      if (map_tex_[k]) gl.DeleteTextures(1, &map_tex_[k]);
      map_fbo_[k] = map_tex_[k] = 0;
    }
    map_size_ = con.shadowSize;
    map_key_.clear();
  }
  // The clip-space depth convention mjr_render set (ARB_clip_control when the driver has it).
  GLint depth_mode = GL_NEGATIVE_ONE_TO_ONE;
  gl.GetIntegerv(GL_CLIP_DEPTH_MODE, &depth_mode);
  const bool zero_to_one = depth_mode == GL_ZERO_TO_ONE;

  // What the maps depend on: the casters, the lights, the square and the depth range.
  const mjvGLCamera cam = mjv_averageCamera(scn.camera, scn.camera + 1);
  std::vector<float> key = {con.shadowClip, con.shadowScale, cam.frustum_near, cam.frustum_far,
                            static_cast<float>(zero_to_one)};
  for (int i : lights) {
    const mjvLight& l = scn.lights[i];
    key.insert(key.end(), {static_cast<float>(l.type), l.pos[0], l.pos[1], l.pos[2], l.dir[0],
                           l.dir[1], l.dir[2], l.cutoff});
  }
  for (int j = 0; j < scn.ngeom; ++j) {
    const mjvGeom& g = scn.geoms[j];
    if (g.category == mjCAT_DECOR) continue;
    key.insert(key.end(), {static_cast<float>(g.type), static_cast<float>(g.dataid)});
    key.insert(key.end(), g.size, g.size + 3);
    key.insert(key.end(), g.pos, g.pos + 3);
    key.insert(key.end(), g.mat, g.mat + 9);
  }
  if (key == map_key_) return;

  for (size_t k = 0; k < lights.size(); ++k) {
    if (map_tex_[k]) continue;
    gl.GenTextures(1, &map_tex_[k]);
    gl.ActiveTexture(GL_TEXTURE0 + kUnitMap0 + static_cast<GLenum>(k));
    gl.BindTexture(GL_TEXTURE_2D, map_tex_[k]);
    gl.TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH24_STENCIL8, map_size_, map_size_, 0, GL_DEPTH_STENCIL,
                  GL_UNSIGNED_INT_24_8, nullptr);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_R_TO_TEXTURE);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_GEQUAL);
    gl.GenFramebuffers(1, &map_fbo_[k]);
    gl.BindFramebuffer(GL_FRAMEBUFFER, map_fbo_[k]);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, map_tex_[k], 0);
    gl.DrawBuffer(GL_NONE);
    gl.ReadBuffer(GL_NONE);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw Error("one-pass shadows: the shadow map framebuffer is incomplete");
    }
  }

  // As mjr_render's shadow-map passes: depth only, flat, no culling, MuJoCo's offsets.
  gl.UseProgram(0);
  gl.Disable(GL_LIGHTING);
  gl.Disable(GL_BLEND);
  gl.ColorMask(0, 0, 0, 0);
  const bool cull = gl.IsEnabled(GL_CULL_FACE);
  gl.Disable(GL_CULL_FACE);
  gl.Enable(GL_POLYGON_OFFSET_FILL);
  gl.PolygonOffset(zero_to_one ? -1.5f : -16.0f, zero_to_one ? -4.0f : -512.0f);
  gl.DepthMask(GL_TRUE);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_GEQUAL);
  for (int t = 0; t < 4; ++t) {
    gl.ActiveTexture(GL_TEXTURE0 + t);
    gl.Disable(GL_TEXTURE_2D);
    gl.Disable(GL_TEXTURE_CUBE_MAP);
  }
  BindShapes(true);
  float bias[16] = {0.5f, 0, 0, 0, 0, 0.5f, 0, 0, 0, 0, 1, 0, 0.5f, 0.5f, 0, 1};
  if (!zero_to_one) bias[10] = bias[14] = 0.5f;
  for (size_t k = 0; k < lights.size(); ++k) {
    const mjvLight& l = scn.lights[lights[k]];
    float up[3];
    OrthoVec(up, l.dir);
    gl.MatrixMode(GL_PROJECTION);
    gl.LoadIdentity();
    if (zero_to_one) {
      gl.Translatef(0, 0, 0.5f);
      gl.Scalef(1, 1, -0.5f);
    } else {
      gl.Scalef(1, 1, -1);
    }
    if (l.type == mjLIGHT_DIRECTIONAL) {
      gl.Ortho(-con.shadowClip, con.shadowClip, -con.shadowClip, con.shadowClip, cam.frustum_near,
               cam.frustum_far);
    } else {
      const double fovy = std::min<double>(2 * l.cutoff * con.shadowScale, 160);
      const double h =
          std::tan(static_cast<double>(static_cast<float>(fovy)) / 360.0 * mjPI) * cam.frustum_near;
      gl.Frustum(-h, h, -h, h, cam.frustum_near, cam.frustum_far);
    }
    float project[16];
    gl.GetFloatv(GL_PROJECTION_MATRIX, project);
    gl.MatrixMode(GL_MODELVIEW);
    gl.LoadIdentity();
    const std::array<float, 16> view = LookAtMatrix(l.pos, l.dir, up);
    gl.MultMatrixf(view.data());
    float view_gl[16];
    gl.GetFloatv(GL_MODELVIEW_MATRIX, view_gl);
    map_matrix_[k] = Mul(bias, Mul(project, view_gl).data());

    gl.BindFramebuffer(GL_FRAMEBUFFER, map_fbo_[k]);
    gl.DrawBuffer(GL_NONE);
    gl.Viewport(0, 0, map_size_, map_size_);
    gl.Clear(GL_DEPTH_BUFFER_BIT);
    gl.Viewport(1, 1, map_size_ - 2, map_size_ - 2);
    for (int j = 0; j < scn.ngeom; ++j) {
      const mjvGeom& g = scn.geoms[j];
      if (g.type == mjGEOM_LINE || g.category == mjCAT_DECOR) continue;
      DrawGeom(gl, g, con, shapes_.get());
    }
  }
  BindShapes(false);
  if (cull) gl.Enable(GL_CULL_FACE);
  gl.Disable(GL_POLYGON_OFFSET_FILL);
  gl.Enable(GL_LIGHTING);
  gl.ColorMask(1, 1, 1, 1);
  map_key_ = std::move(key);
  ++map_renders_;
}

void ShadowPass::Render(const mjrRect& viewport, mjvScene* scn, const mjrContext* con) {
  Gl& gl = *gl_;
  // mjr_render without its shadows: reflection, every light, skybox. Its opaque geoms are
  // drawn over below; its depth buffer says which fragments are in front.
  // The reflective geom (mjr_render keeps the first) is added over its reflection: black
  // there, so that this pass adds it with its shadows, as mjr_render's passes sum it.
  int reflective = -1;
  for (int j = 0; j < scn->ngeom && reflective < 0; ++j) {
    const mjvGeom& g = scn->geoms[j];
    if ((g.type == mjGEOM_PLANE || g.type == mjGEOM_BOX) && g.reflectance > 0) reflective = j;
  }
  float saved[4] = {0, 0, 0, 0};
  if (reflective >= 0) {
    mjvGeom& g = scn->geoms[reflective];
    std::memcpy(saved, g.rgba, 3 * sizeof(float));
    saved[3] = g.specular;
    g.rgba[0] = g.rgba[1] = g.rgba[2] = 0;
    g.specular = 0;
  }
  scn->flags[mjRND_SHADOW] = 0;
  mjr_render(viewport, scn, con);
  scn->flags[mjRND_SHADOW] = 1;
  if (reflective >= 0) {
    mjvGeom& g = scn->geoms[reflective];
    std::memcpy(g.rgba, saved, 3 * sizeof(float));
    g.specular = saved[3];
  }

  std::vector<int> lights;  // shadow-casting lights, in map order
  for (int i = 0; i < scn->nlight; ++i) {
    if (Supported(scn->lights[i]) && scn->lights[i].castshadow) lights.push_back(i);
  }
  float cam_project[16], cam_view[16];
  gl.GetFloatv(GL_PROJECTION_MATRIX, cam_project);
  gl.GetFloatv(GL_MODELVIEW_MATRIX, cam_view);

  DrawMaps(*scn, *con, lights);

  gl.BindFramebuffer(GL_FRAMEBUFFER, con->offFBO);
  gl.DrawBuffer(GL_COLOR_ATTACHMENT0);
  gl.Viewport(viewport.left, viewport.bottom, viewport.width, viewport.height);
  gl.MatrixMode(GL_PROJECTION);
  gl.LoadMatrixf(cam_project);
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadMatrixf(cam_view);
  // mjr_render's opaque geoms drawn over, through its depth buffer: the same display lists
  // under the same matrices give the same depths.
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_GEQUAL);
  gl.DepthMask(GL_FALSE);
  int nlight_supported = 0;
  for (int i = 0; i < scn->nlight; ++i) nlight_supported += Supported(scn->lights[i]);
  const GLuint program = Program(nlight_supported, static_cast<int>(lights.size()));
  gl.UseProgram(program);

  auto loc = [&](const char* name) { return gl.GetUniformLocation(program, name); };
  // Lights in eye coordinates, as mjr_render's adjustLight sets them under the camera view.
  int nlight = 0;
  float lpos[kMaxLights][4] = {}, lspotdir[kMaxLights][3] = {}, lspot[kMaxLights][3] = {},
        latt[kMaxLights][3] = {}, lamb[kMaxLights][3] = {}, ldif[kMaxLights][3] = {},
        lspec[kMaxLights][3] = {};
  int lslot[kMaxLights] = {};
  auto eye = [&](const float* v, float w, float* out) {
    for (int r = 0; r < 3; ++r) {
      out[r] = cam_view[r] * v[0] + cam_view[4 + r] * v[1] + cam_view[8 + r] * v[2] +
               cam_view[12 + r] * w;
    }
  };
  int supported = 0;
  for (int i = 0; i < scn->nlight; ++i) {
    const mjvLight& l = scn->lights[i];
    if (!Supported(l)) continue;
    ++supported;
    const int n = nlight++;
    if (l.type == mjLIGHT_DIRECTIONAL) {
      const float d[3] = {-l.dir[0], -l.dir[1], -l.dir[2]};
      eye(d, 0, lpos[n]);
      lpos[n][3] = 0;
      latt[n][0] = 1;
      lspot[n][0] = -1;
    } else {
      eye(l.pos, 1, lpos[n]);
      lpos[n][3] = 1;
      eye(l.dir, 0, lspotdir[n]);
      for (int k = 0; k < 3; ++k) latt[n][k] = l.attenuation[k];
      lspot[n][0] = static_cast<float>(std::cos(static_cast<double>(l.cutoff) * mjPI / 180.0));
      lspot[n][1] = l.exponent;
      lspot[n][2] = 1;
    }
    for (int k = 0; k < 3; ++k) {
      lamb[n][k] = l.ambient[k];
      ldif[n][k] = l.diffuse[k];
      lspec[n][k] = l.specular[k];
    }
    lslot[n] = -1;
    for (size_t k = 0; k < lights.size(); ++k) {
      if (lights[k] == i) lslot[n] = static_cast<int>(k);
    }
  }
  gl.Uniform4fv(loc("u_lpos"), nlight, &lpos[0][0]);
  gl.Uniform3fv(loc("u_lspotdir"), nlight, &lspotdir[0][0]);
  gl.Uniform3fv(loc("u_lspot"), nlight, &lspot[0][0]);
  gl.Uniform3fv(loc("u_latt"), nlight, &latt[0][0]);
  gl.Uniform3fv(loc("u_lamb"), nlight, &lamb[0][0]);
  gl.Uniform3fv(loc("u_ldif"), nlight, &ldif[0][0]);
  gl.Uniform3fv(loc("u_lspec"), nlight, &lspec[0][0]);
  gl.Uniform1iv(loc("u_lslot"), nlight, lslot);
  const float global = supported ? 0.0f : 0.3f;
  const float global3[3] = {global, global, global};
  gl.Uniform3fv(loc("u_global"), 1, global3);
  const std::array<float, 16> inv_view = InverseRigid(cam_view);
  float eye_to_map[kMaxShadowLights][16] = {};
  for (size_t k = 0; k < lights.size(); ++k) {
    const std::array<float, 16> m = Mul(map_matrix_[k].data(), inv_view.data());
    std::memcpy(eye_to_map[k], m.data(), sizeof eye_to_map[k]);
  }
  gl.UniformMatrix4fv(loc("u_eye_to_map"), kMaxShadowLights, GL_FALSE, &eye_to_map[0][0]);
  gl.Uniform1i(loc("u_tex2d"), kUnit2d);
  gl.Uniform1i(loc("u_texcube"), kUnitCube);
  const char* map_names[kMaxShadowLights] = {"u_map0", "u_map1", "u_map2", "u_map3"};
  for (int k = 0; k < kMaxShadowLights; ++k) {
    const size_t slot = std::min<size_t>(k, lights.size() - 1);
    gl.ActiveTexture(GL_TEXTURE0 + kUnitMap0 + k);
    gl.BindTexture(GL_TEXTURE_2D, map_tex_[slot]);
    gl.Uniform1i(loc(map_names[k]), kUnitMap0 + k);
  }
  const GLint u_rgba = loc("u_rgba"), u_emission = loc("u_emission"),
              u_specular = loc("u_specular"), u_shininess = loc("u_shininess"),
              u_texmode_v = loc("u_texmode"), u_s = loc("u_plane_s"), u_t = loc("u_plane_t"),
              u_r = loc("u_plane_r");

  for (int j = 0; j < scn->ngeom; ++j) {
    const mjvGeom& g = scn->geoms[j];
    gl.Uniform4fv(u_rgba, 1, g.rgba);
    gl.Uniform1f(u_emission, g.emission);
    gl.Uniform1f(u_specular, g.specular);
    gl.Uniform1f(u_shininess, g.shininess * 128.0f);
    const GeomTexture tex = TextureOf(g, *con);
    gl.Uniform1i(u_texmode_v, tex.mode);
    gl.Uniform4fv(u_s, 1, tex.s);
    gl.Uniform4fv(u_t, 1, tex.t);
    gl.Uniform4fv(u_r, 1, tex.r);
    if (tex.mode == 3) {
      gl.ActiveTexture(GL_TEXTURE0 + kUnitCube);
      gl.BindTexture(GL_TEXTURE_CUBE_MAP, tex.texture);
    } else if (tex.mode != 0) {
      gl.ActiveTexture(GL_TEXTURE0 + kUnit2d);
      gl.BindTexture(GL_TEXTURE_2D, tex.texture);
    }
    if (j == reflective) {
      gl.Enable(GL_BLEND);
      gl.BlendFunc(GL_ONE, GL_ONE);
    }
    DrawGeom(gl, g, *con, nullptr);
    if (j == reflective) gl.Disable(GL_BLEND);
  }

  gl.UseProgram(0);
  gl.DepthMask(GL_TRUE);
  for (int t = kMaxShadowLights + kUnitMap0 - 1; t >= 0; --t) {
    gl.ActiveTexture(GL_TEXTURE0 + t);
    gl.BindTexture(GL_TEXTURE_2D, 0);
  }
  gl.ActiveTexture(GL_TEXTURE0 + kUnitCube);
  gl.BindTexture(GL_TEXTURE_CUBE_MAP, 0);
  gl.ActiveTexture(GL_TEXTURE0);
}

}  // namespace mlspaces::sim
