#include "shadow_pass.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "mlspaces/core/error.h"
#include "shadow_pass_gl.h"

namespace mlspaces::sim {

using namespace detail;  // NOLINT(google-build-using-namespace): this file's own helpers

// A program's uniform locations for the per-geom state.
struct ShadowPass::GeomUniforms {
  GLint rgba, emission, specular, shininess, s, t, r, alpha;
};

struct ShadowPass::BuiltProgram {
  GLuint id = 0;
  // SetLights' uniforms, the maps' matrices, the per-geom state.
  GLint lpos, lspotdir, lspot, latt, lamb, ldif, lspec, lslot, global, eye_to_map;
  GeomUniforms geom;
};

ShadowPass::ShadowPass(GlProcLoader load, const mjModel* m, bool coarse_sides, bool nearest_mipmap)
    : gl_(std::make_unique<Gl>()),
      // The maps' shapes: coarser than MuJoCo's (their vertices are most of a map's cost), an
      // error under a millimetre on a 6 cm capsule, below the maps' texels.
      shapes_(std::make_unique<IndexedShapes>(
          IndexShapes(MakeBuiltinShapes(std::min(m->vis.quality.numslices, kMapSlices),
                                        std::min(m->vis.quality.numstacks, kMapStacks), 1, 1)))) {
  Gl& gl = *gl_;
#define MLSPACES_LOAD(name)                                            \
  gl.name = reinterpret_cast<decltype(&::gl##name)>(load("gl" #name)); \
  if (gl.name == nullptr) {                                            \
    throw Error("one-pass shadows: the GL library has no gl" #name);   \
  }
  MLSPACES_SHADOW_PASS_GL(MLSPACES_LOAD)
#undef MLSPACES_LOAD
  // As MuJoCo's loader decides: glClipControl when the driver lists ARB_clip_control.
  const auto* extensions = reinterpret_cast<const char*>(gl.GetString(GL_EXTENSIONS));
  if (extensions != nullptr && std::strstr(extensions, "GL_ARB_clip_control") != nullptr) {
    gl.ClipControl = reinterpret_cast<decltype(gl.ClipControl)>(load("glClipControl"));
  }
  if (nearest_mipmap && extensions != nullptr &&
      std::strstr(extensions, "GL_ARB_sampler_objects") != nullptr) {
    gl.GenSamplers = reinterpret_cast<decltype(gl.GenSamplers)>(load("glGenSamplers"));
    gl.DeleteSamplers = reinterpret_cast<decltype(gl.DeleteSamplers)>(load("glDeleteSamplers"));
    gl.SamplerParameteri =
        reinterpret_cast<decltype(gl.SamplerParameteri)>(load("glSamplerParameteri"));
    gl.BindSampler = reinterpret_cast<decltype(gl.BindSampler)>(load("glBindSampler"));
    if (gl.GenSamplers != nullptr && gl.DeleteSamplers != nullptr &&
        gl.SamplerParameteri != nullptr && gl.BindSampler != nullptr) {
      // mjr_uploadTexture's wrap modes and magnification; one mipmap level, not two blended.
      for (auto [sampler, wrap] :
           {std::pair{&sampler_2d_, GL_REPEAT}, std::pair{&sampler_cube_, GL_CLAMP_TO_EDGE}}) {
        gl.GenSamplers(1, sampler);
        for (GLenum coord : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) {
          gl.SamplerParameteri(*sampler, coord, wrap);
        }
        gl.SamplerParameteri(*sampler, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        gl.SamplerParameteri(*sampler, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_NEAREST);
      }
    }
  }
  // The shaders build here once, so that a driver without GLSL 1.20 fails at construction.
  Program(1, 1, 0);
  gl.GenBuffers(1, &caster_buffer_);
  gl.GenBuffers(1, &caster_index_buffer_);
  if (coarse_sides) coarse_ = std::make_unique<CoarseSides>(MakeCoarseSides(gl, m));
  // Meshes are drawn from mesh_vert in the geom's frame (mjr_uploadMesh).
  model_ = m;
  mesh_closed_.assign(static_cast<size_t>(m->nmesh), -1);
  mesh_radius_.resize(static_cast<size_t>(m->nmesh));
  for (int i = 0; i < m->nmesh; ++i) {
    double r2 = 0;
    const float* v = m->mesh_vert + 3 * static_cast<size_t>(m->mesh_vertadr[i]);
    for (int k = 0; k < m->mesh_vertnum[i]; ++k, v += 3) {
      r2 = std::max(r2, static_cast<double>(v[0]) * v[0] + static_cast<double>(v[1]) * v[1] +
                            static_cast<double>(v[2]) * v[2]);
    }
    mesh_radius_[static_cast<size_t>(i)] = static_cast<float>(std::sqrt(r2));
  }
}

bool ShadowPass::LeftOut(const ViewVolume& volume, const mjvGeom& g) {
  const bool out = Outside(volume, g.pos, DrawnRadius(g, mesh_radius_));
  left_out_ += out;
  return out;
}

const ShadowPass::BuiltProgram& ShadowPass::Program(int nlight, int nmap, int texmode) {
  const int key = (nlight * (kMaxShadowLights + 1) + nmap) * 4 + texmode;
  if (auto it = programs_.find(key); it != programs_.end()) return *it->second;
  Gl& gl = *gl_;
  const std::string defines = "#version 120\n#define NLIGHT " + std::to_string(nlight) +
                              "\n#define NMAP " + std::to_string(nmap) + "\n#define TEXMODE " +
                              std::to_string(texmode) + "\n";
  // One line, whatever the driver's log holds.
  auto fail = [](const std::string& what, const char* log) {
    std::string line(log);
    for (char& c : line) c = c == '\n' ? ' ' : c;
    throw Error("one-pass shadows: the shader does not " + what + ": " + line);
  };
  auto compile = [&](GLenum kind, const char* body) {
    const std::string text = defines + kVaryings + body;
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
      fail("compile", log);
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
    fail("link", log);
  }
  auto built = std::make_unique<BuiltProgram>();
  built->id = program;
  auto loc = [&](const char* name) { return gl.GetUniformLocation(program, name); };
  BuiltProgram& b = *built;
  b.lpos = loc("u_lpos");
  b.lspotdir = loc("u_lspotdir");
  b.lspot = loc("u_lspot");
  b.latt = loc("u_latt");
  b.lamb = loc("u_lamb");
  b.ldif = loc("u_ldif");
  b.lspec = loc("u_lspec");
  b.lslot = loc("u_lslot");
  b.global = loc("u_global");
  b.eye_to_map = loc("u_eye_to_map");
  b.geom = {loc("u_rgba"),    loc("u_emission"), loc("u_specular"), loc("u_shininess"),
            loc("u_plane_s"), loc("u_plane_t"),  loc("u_plane_r"),  loc("u_alpha")};
  // The samplers' texture units never change (uniforms are the program's state).
  gl.UseProgram(program);
  gl.Uniform1i(loc("u_tex2d"), kUnit2d);
  gl.Uniform1i(loc("u_texcube"), kUnitCube);
  const char* map_names[kMaxShadowLights] = {"u_map0", "u_map1", "u_map2", "u_map3"};
  for (int k = 0; k < kMaxShadowLights; ++k) gl.Uniform1i(loc(map_names[k]), kUnitMap0 + k);
  gl.UseProgram(0);
  return *(programs_[key] = std::move(built));
}

ShadowPass::~ShadowPass() {
  Gl& gl = *gl_;
  if (caster_buffer_) gl.DeleteBuffers(1, &caster_buffer_);
  if (caster_index_buffer_) gl.DeleteBuffers(1, &caster_index_buffer_);
  if (coarse_ && coarse_->buffer) gl.DeleteBuffers(1, &coarse_->buffer);
  for (int k = 0; k < kMaxShadowLights; ++k) {
    if (map_fbo_[k]) gl.DeleteFramebuffers(1, &map_fbo_[k]);
    if (map_tex_[k]) gl.DeleteTextures(1, &map_tex_[k]);
  }
  for (const auto& [key, program] : programs_) gl.DeleteProgram(program->id);
  for (unsigned int sampler : {sampler_2d_, sampler_cube_}) {
    if (sampler) gl.DeleteSamplers(1, &sampler);
  }
}

void ShadowPass::BindSamplers(bool on) {
  if (!sampler_2d_) return;
  gl_->BindSampler(kUnit2d, on ? sampler_2d_ : 0);
  gl_->BindSampler(kUnitCube, on ? sampler_cube_ : 0);
}

bool ShadowPass::HasShadows(const mjvScene& scn, const mjrContext& con) {
  if (!scn.flags[mjRND_SHADOW] || !con.shadowFBO || con.shadowSize <= 2) return false;
  for (int i = 0; i < scn.nlight; ++i) {
    if (scn.lights[i].castshadow) return true;
  }
  return false;
}

const char* ShadowPass::Unsupported(const mjvScene& scn, const mjrContext& con, int* geom) const {
  if (geom != nullptr) *geom = -1;
  if (!HasShadows(scn, con)) return "no shadows";
  if (scn.flags[mjRND_FOG]) return "fog";
  if (scn.flags[mjRND_SEGMENT] || scn.flags[mjRND_IDCOLOR]) return "segmentation";
  if (scn.flags[mjRND_WIREFRAME]) return "wireframe";
  if (scn.flags[mjRND_DEPTH]) return "depth rendering";
  if (scn.stereo != mjSTEREO_NONE) return "stereo";
  if (scn.framewidth > 0) return "a frame";
  if (scn.enabletransform) return "a scene transform";
  if (scn.nskin > 0) return "skins";
  if (scn.nlight > kMaxLights) return "more than 8 lights";
  int shadow_lights = 0;
  for (int i = 0; i < scn.nlight; ++i) {
    // MuJoCo 3.5 enables point and image lights with the last position set: left to it.
    if (!Supported(scn.lights[i])) return "a point or image light";
    shadow_lights += scn.lights[i].castshadow;
  }
  if (shadow_lights > kMaxShadowLights) return "more than 4 shadow-casting lights";
  float head[3];
  HeadPos(scn, head);
  for (int i = 0; i < scn.ngeom; ++i) {
    const mjvGeom& g = scn.geoms[i];
    const char* why = !DrawnType(g.type)                          ? "a geom type it does not draw"
                      : g.label[0] != '\0'                        ? "a label"
                      : g.type == mjGEOM_PLANE && Behind(head, g) ? "a plane seen from behind"
                                                                  : nullptr;
    if (why != nullptr) {
      if (geom != nullptr) *geom = i;
      return why;
    }
  }
  return nullptr;
}

struct ShadowPass::Programs {
  Programs(ShadowPass* owner, const mjvScene& scene, const float* modelview,
           std::vector<int> maps = {}, const float* map_matrices = nullptr)
      : pass(*owner),
        scn(scene),
        view(modelview),
        shadow_lights(std::move(maps)),
        eye_to_map(map_matrices) {
    for (int i = 0; i < scn.nlight; ++i) nlight += Supported(scn.lights[i]);
  }
  // Makes the program for `texmode` current (set up for this pass on first use); its
  // per-geom uniforms.
  const GeomUniforms& Use(int texmode);

  ShadowPass& pass;
  const mjvScene& scn;
  const float* view;               // the pass's modelview: lights in eye coordinates
  std::vector<int> shadow_lights;  // in map order
  const float* eye_to_map;         // kMaxShadowLights matrices (column-major), with maps
  int nlight = 0;
  std::array<const BuiltProgram*, 4> program{};  // set up for this pass
  int current = -1;
};

const ShadowPass::GeomUniforms& ShadowPass::Programs::Use(int texmode) {
  Gl& gl = *pass.gl_;
  if (texmode == current) return program[texmode]->geom;
  current = texmode;
  if (program[texmode] != nullptr) {
    gl.UseProgram(program[texmode]->id);
    return program[texmode]->geom;
  }
  const BuiltProgram& p = pass.Program(nlight, static_cast<int>(shadow_lights.size()), texmode);
  program[texmode] = &p;
  gl.UseProgram(p.id);
  pass.SetLights(p, scn, view, shadow_lights);
  if (!shadow_lights.empty()) {
    gl.UniformMatrix4fv(p.eye_to_map, kMaxShadowLights, GL_FALSE, eye_to_map);
  }
  return p.geom;
}

namespace {

// renderGeom's material and texture for `g` (its rgb times `rgb_scale`, as a reflection),
// with the program for its texture mode. The alpha written is the geom's (blending reads it),
// or, when `id` >= 0, the byte `id` (the lit pass's tracked geoms, Render's `ids`; 0: none).
void SetGeom(const ShadowPass::Gl& gl, ShadowPass::Programs& programs, const mjvGeom& g,
             const mjrContext& con, float rgb_scale, int id = -1) {
  const GeomTexture tex = TextureOf(g, con);
  const ShadowPass::GeomUniforms& u = programs.Use(tex.mode);
  const float rgba[4] = {g.rgba[0] * rgb_scale, g.rgba[1] * rgb_scale, g.rgba[2] * rgb_scale,
                         g.rgba[3]};
  gl.Uniform4fv(u.rgba, 1, rgba);
  if (id < 0) {
    gl.Uniform2f(u.alpha, 1, 0);
  } else {
    // A quarter above the id: the same byte whether the driver rounds or truncates.
    gl.Uniform2f(u.alpha, 0, (static_cast<float>(id) + 0.25f) / 255.0f);
  }
  gl.Uniform1f(u.emission, g.emission);
  gl.Uniform1f(u.specular, g.specular);
  gl.Uniform1f(u.shininess, g.shininess * 128.0f);
  if (tex.mode == 0) return;
  gl.Uniform4fv(u.s, 1, tex.s);
  gl.Uniform4fv(u.t, 1, tex.t);
  gl.Uniform4fv(u.r, 1, tex.r);
  if (tex.mode == 3) {
    gl.ActiveTexture(GL_TEXTURE0 + kUnitCube);
    gl.BindTexture(GL_TEXTURE_CUBE_MAP, tex.texture);
  } else {
    gl.ActiveTexture(GL_TEXTURE0 + kUnit2d);
    gl.BindTexture(GL_TEXTURE_2D, tex.texture);
  }
}

// mjr_reflect's matrix (column-major) for a plane at `pos` with normal mat's z axis.
std::array<float, 16> ReflectMatrix(const float* pos, const float* mat) {
  const float v[3] = {mat[2], mat[5], mat[8]};
  std::array<float, 16> r{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[4 * i + j] = (i == j ? 1.0f : 0.0f) - 2 * v[i] * v[j];
  }
  const float d = pos[0] * v[0] + pos[1] * v[1] + pos[2] * v[2];
  for (int i = 0; i < 3; ++i) r[12 + i] = 2 * d * v[i];
  r[15] = 1;
  return r;
}

// mjr_render's transparent geoms (setting mjvGeom::transparent and camdist as it does), seen
// from the eye at `head` (HeadPos).
std::vector<int> SortTransparent(mjvScene* scn, const float* head) {
  // As mjr_render: alpha under 0.995 (planes seen from behind too, which Unsupported leaves
  // to mjr_render), nearest first by the distance to the head less the bounding radius, in
  // a stable order (MuJoCo's merge sort).
  std::vector<int> order;
  for (int i = 0; i < scn->ngeom; ++i) {
    mjvGeom& g = scn->geoms[i];
    g.transparent = g.rgba[3] < 0.995f || (g.type == mjGEOM_PLANE && Behind(head, g));
    if (!g.transparent) continue;
    const float d[3] = {g.pos[0] - head[0], g.pos[1] - head[1], g.pos[2] - head[2]};
    g.camdist = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    g.camdist -= Rbound(g);
    if (g.type == mjGEOM_PLANE) g.camdist = 1e10f;
    order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return scn->geoms[a].camdist < scn->geoms[b].camdist; });
  return order;
}

// The transparent geoms, blended as mjr_render draws them.
void DrawBlended(const ShadowPass::Gl& gl, const mjvScene& scn, const mjrContext& con,
                 ShadowPass::Programs& programs, const std::vector<int>& transparent,
                 float rgb_scale) {
  if (transparent.empty()) return;
  // mjr_render's blending: nearest first, then (unless additive) farthest first; no depth.
  gl.DepthMask(GL_FALSE);
  gl.Enable(GL_BLEND);
  const bool additive = scn.flags[mjRND_ADDITIVE];
  gl.BlendFunc(GL_SRC_ALPHA, additive ? GL_ONE : GL_ONE_MINUS_SRC_ALPHA);
  for (int j : transparent) {
    SetGeom(gl, programs, scn.geoms[j], con, rgb_scale);
    DrawGeom(gl, scn.geoms[j], con);
  }
  if (!additive) {
    for (auto it = transparent.rbegin(); it != transparent.rend(); ++it) {
      SetGeom(gl, programs, scn.geoms[*it], con, rgb_scale);
      DrawGeom(gl, scn.geoms[*it], con);
    }
  }
  gl.DepthMask(GL_TRUE);
  gl.Disable(GL_BLEND);
}

}  // namespace

void ShadowPass::SetLights(const BuiltProgram& program, const mjvScene& scn, const float* view,
                           const std::vector<int>& shadow_lights) {
  Gl& gl = *gl_;
  // Lights in eye coordinates, as mjr_render's adjustLight sets them under `view`.
  int nlight = 0;
  float lpos[kMaxLights][4] = {}, lspotdir[kMaxLights][3] = {}, lspot[kMaxLights][3] = {},
        latt[kMaxLights][3] = {}, lamb[kMaxLights][3] = {}, ldif[kMaxLights][3] = {},
        lspec[kMaxLights][3] = {};
  int lslot[kMaxLights] = {};
  auto eye = [&](const float* v, float w, float* out) {
    for (int r = 0; r < 3; ++r) {
      out[r] = view[r] * v[0] + view[4 + r] * v[1] + view[8 + r] * v[2] + view[12 + r] * w;
    }
  };
  for (int i = 0; i < scn.nlight; ++i) {
    const mjvLight& l = scn.lights[i];
    if (!Supported(l)) continue;
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
    for (size_t k = 0; k < shadow_lights.size(); ++k) {
      if (shadow_lights[k] == i) lslot[n] = static_cast<int>(k);
    }
  }
  gl.Uniform4fv(program.lpos, nlight, &lpos[0][0]);
  gl.Uniform3fv(program.lspotdir, nlight, &lspotdir[0][0]);
  gl.Uniform3fv(program.lspot, nlight, &lspot[0][0]);
  gl.Uniform3fv(program.latt, nlight, &latt[0][0]);
  gl.Uniform3fv(program.lamb, nlight, &lamb[0][0]);
  gl.Uniform3fv(program.ldif, nlight, &ldif[0][0]);
  gl.Uniform3fv(program.lspec, nlight, &lspec[0][0]);
  gl.Uniform1iv(program.lslot, nlight, lslot);
  // MuJoCo 3.5 adds a global ambient only to a scene without lights.
  const float global = scn.nlight ? 0.0f : 0.3f;
  const float global3[3] = {global, global, global};
  gl.Uniform3fv(program.global, 1, global3);
}

void ShadowPass::DrawSkybox(const mjvScene& scn, const mjrContext& con, const float* head) {
  Gl& gl = *gl_;
  if (!scn.flags[mjRND_SKYBOX]) return;
  // As mjr_render after its shadows: a cylinder around the head with the first skybox
  // texture (the one mjr_makeContext puts on the last material), then the haze of the first
  // infinite plane; unlit, inner faces, behind the geoms through the depth test.
  bool has_skybox = false;
  for (int i = 0; i < con.ntexture && !has_skybox; ++i) {
    has_skybox = con.textureType[i] == mjTEXTURE_SKYBOX;
  }
  if (!has_skybox) return;
  const int texid = con.mat_texid[mjNTEXROLE * (mjMAXMATERIAL - 1) + mjTEXROLE_RGB];
  const float distance = mjv_averageCamera(scn.camera, scn.camera + 1).frustum_far * 0.70f;
  gl.UseProgram(0);
  gl.Disable(GL_LIGHTING);
  gl.Disable(GL_COLOR_MATERIAL);
  gl.CullFace(GL_FRONT);
  gl.PushMatrix();
  gl.Translatef(head[0], head[1], head[2]);
  gl.Scalef(distance, distance, distance);
  gl.ActiveTexture(GL_TEXTURE0);
  if (texid >= 0) {
    gl.Enable(GL_TEXTURE_CUBE_MAP);
    const GLenum coords[3] = {GL_S, GL_T, GL_R};
    // mjr_render's mapping: rotated 90 degrees about x.
    const float planes[3][4] = {{1, 0, 0, 0}, {0, 0, 1, 0}, {0, -1, 0, 0}};
    for (int k = 0; k < 3; ++k) {
      gl.Enable(GL_TEXTURE_GEN_S + k);
      gl.TexGeni(coords[k], GL_TEXTURE_GEN_MODE, GL_OBJECT_LINEAR);
      gl.TexGenfv(coords[k], GL_OBJECT_PLANE, planes[k]);
    }
    gl.BindTexture(GL_TEXTURE_CUBE_MAP, con.texture[texid]);
  }
  gl.Color4f(1, 1, 1, 1);
  gl.CallList(con.baseBuiltin + kShapeCylinder);
  gl.Disable(GL_TEXTURE_CUBE_MAP);
  for (int k = 0; k < 3; ++k) gl.Disable(GL_TEXTURE_GEN_S + k);
  if (scn.flags[mjRND_HAZE]) {
    for (int j = 0; j < scn.ngeom; ++j) {
      const mjvGeom& g = scn.geoms[j];
      if (g.type != mjGEOM_PLANE || g.size[0] != 0 || g.size[1] != 0) continue;
      const float* r = g.mat;
      const float elevation = ((head[0] - g.pos[0]) * r[2] + (head[1] - g.pos[1]) * r[5] +
                               (head[2] - g.pos[2]) * r[8]) /
                              distance;
      if (elevation >= 0) {
        const float rotation[16] = {r[0], r[3], r[6], 0, r[1], r[4], r[7], 0,
                                    r[2], r[5], r[8], 0, 0,    0,    0,    1};
        gl.MultMatrixf(rotation);
        gl.Translatef(0, 0, -elevation);
        gl.Scalef(1, 1, elevation);
        gl.Enable(GL_BLEND);
        gl.BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
        gl.CallList(con.baseBuiltin + kShapeHaze);
        gl.Disable(GL_BLEND);
      }
      break;  // the first infinite plane only
    }
  }
  gl.PopMatrix();
  gl.Enable(GL_LIGHTING);
  gl.Enable(GL_COLOR_MATERIAL);
  gl.CullFace(GL_BACK);
}

void ShadowPass::BeginFrame(const mjrRect& viewport, const mjvScene& scn, const mjrContext& con,
                            float* cam_project, float* cam_view) {
  Gl& gl = *gl_;
  // As mjr_render's initGL3, clear and setView (mono, no scene transform).
  const bool zero_to_one = gl.ClipControl != nullptr;
  if (zero_to_one) gl.ClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
  gl.BindFramebuffer(GL_FRAMEBUFFER, con.offFBO);
  gl.DrawBuffer(GL_COLOR_ATTACHMENT0);
  gl.UseProgram(0);
  gl.Enable(GL_MULTISAMPLE);
  gl.Disable(GL_BLEND);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthMask(GL_TRUE);
  if (scn.flags[mjRND_CULL_FACE]) {
    gl.Enable(GL_CULL_FACE);
  } else {
    gl.Disable(GL_CULL_FACE);
  }
  gl.CullFace(GL_BACK);
  gl.FrontFace(GL_CCW);
  gl.DepthFunc(GL_GEQUAL);
  gl.ClearColor(0, 0, 0, 0);
  gl.ClearDepth(0);
  gl.ClearStencil(0);
  gl.ColorMask(1, 1, 1, 1);
  gl.Viewport(viewport.left, viewport.bottom, viewport.width, viewport.height);
  gl.Scissor(viewport.left, viewport.bottom, viewport.width, viewport.height);
  gl.Enable(GL_SCISSOR_TEST);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  gl.Disable(GL_SCISSOR_TEST);

  const mjvGLCamera cam = mjv_averageCamera(scn.camera, scn.camera + 1);
  const float halfwidth = cam.frustum_width ? cam.frustum_width
                                            : 0.5f * static_cast<float>(viewport.width) /
                                                  static_cast<float>(viewport.height) *
                                                  (cam.frustum_top - cam.frustum_bottom);
  LoadReversedDepth(gl, zero_to_one);
  if (cam.orthographic) {
    gl.Ortho(cam.frustum_center - halfwidth, cam.frustum_center + halfwidth, cam.frustum_bottom,
             cam.frustum_top, cam.frustum_near, cam.frustum_far);
  } else {
    gl.Frustum(cam.frustum_center - halfwidth, cam.frustum_center + halfwidth, cam.frustum_bottom,
               cam.frustum_top, cam.frustum_near, cam.frustum_far);
  }
  gl.GetFloatv(GL_PROJECTION_MATRIX, cam_project);
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadIdentity();
  const std::array<float, 16> view = LookAtMatrix(cam.pos, cam.forward, cam.up);
  gl.MultMatrixf(view.data());
  gl.GetFloatv(GL_MODELVIEW_MATRIX, cam_view);
}

void ShadowPass::DrawReflection(const mjvScene& scn, const mjrContext& con, int reflective,
                                const float* head, const float* cam_project, const float* cam_view,
                                const std::vector<int>& transparent) {
  Gl& gl = *gl_;
  if (reflective < 0 || !scn.flags[mjRND_REFLECTION]) return;
  // As mjr_render: a box reflects in its +z face.
  mjvGeom plane = scn.geoms[reflective];
  if (plane.type == mjGEOM_BOX) {
    plane.type = mjGEOM_PLANE;
    for (int i = 0; i < 3; ++i) plane.pos[i] += plane.size[2] * plane.mat[3 * i + 2];
  }
  if (Behind(head, plane)) return;
  // The plane into the stencil buffer, then the mirrored scene where it is.
  gl.UseProgram(0);
  gl.Disable(GL_DEPTH_TEST);
  gl.ColorMask(0, 0, 0, 0);
  gl.Enable(GL_STENCIL_TEST);
  gl.Clear(GL_STENCIL_BUFFER_BIT);
  gl.StencilFunc(GL_ALWAYS, 1, 0xFF);
  gl.StencilOp(GL_REPLACE, GL_REPLACE, GL_REPLACE);
  DrawGeom(gl, plane, con);
  gl.Enable(GL_DEPTH_TEST);
  gl.ColorMask(1, 1, 1, 0);  // the alpha stays the clear's 0 for the lit pass's ids
  gl.StencilFunc(GL_EQUAL, 1, 0xFF);
  gl.StencilOp(GL_KEEP, GL_KEEP, GL_KEEP);
  const double n[3] = {plane.mat[2], plane.mat[5], plane.mat[8]};
  const double clip[4] = {-n[0], -n[1], -n[2],
                          plane.pos[0] * n[0] + plane.pos[1] * n[1] + plane.pos[2] * n[2]};
  gl.Enable(GL_CLIP_PLANE0);
  gl.ClipPlane(GL_CLIP_PLANE0, clip);
  gl.FrontFace(GL_CW);
  gl.PushMatrix();
  const std::array<float, 16> reflect = ReflectMatrix(plane.pos, plane.mat);
  gl.MultMatrixf(reflect.data());
  const std::array<float, 16> mirrored = Mul(cam_view, reflect.data());

  // Every light, no shadows, each geom's colour times the plane's reflectance.
  Programs programs(this, scn, mirrored.data());
  const ViewVolume mirror_volume = ViewVolumeOf(Mul(cam_project, mirrored.data()).data());
  // The eye mirrored: the reflected geoms are seen from there.
  float height = 0;
  for (int i = 0; i < 3; ++i) height += (head[i] - plane.pos[i]) * static_cast<float>(n[i]);
  float mirrored_head[3];
  for (int i = 0; i < 3; ++i) mirrored_head[i] = head[i] - 2 * height * static_cast<float>(n[i]);
  for (int j = 0; j < scn.ngeom; ++j) {
    if (j == reflective || scn.geoms[j].transparent) continue;
    if (LeftOut(mirror_volume, scn.geoms[j])) continue;
    SetGeom(gl, programs, scn.geoms[j], con, plane.reflectance);
    DrawGeom(gl, scn.geoms[j], con, Coarse(scn.geoms[j], mirrored_head));
  }
  DrawBlended(gl, scn, con, programs, transparent, plane.reflectance);
  gl.UseProgram(0);
  gl.PopMatrix();
  gl.FrontFace(GL_CCW);
  gl.Disable(GL_CLIP_PLANE0);
  gl.Disable(GL_STENCIL_TEST);
  gl.ColorMask(1, 1, 1, 1);
}

const CoarseLevel* ShadowPass::Coarse(const mjvGeom& g, const float* eye) {
  if (!coarse_) return nullptr;
  const CoarseLevel* level = CoarseLevelFor(*coarse_, g, eye, coarse_points_.data(),
                                            static_cast<int>(coarse_points_.size() / 3));
  coarse_draws_ += level != nullptr;
  return level;
}

void ShadowPass::Render(const mjrRect& viewport, mjvScene* scn, const mjrContext* con, bool fitted,
                        const std::vector<unsigned char>* ids) {
  Gl& gl = *gl_;
  float head[3];  // the eye, for the whole frame
  HeadPos(*scn, head);
  const std::vector<int> transparent = SortTransparent(scn, head);
  // The reflective geom: mjr_render keeps the first opaque one.
  int reflective = -1;
  for (int j = 0; j < scn->ngeom && reflective < 0; ++j) {
    const mjvGeom& g = scn->geoms[j];
    if ((g.type == mjGEOM_PLANE || g.type == mjGEOM_BOX) && g.reflectance > 0 && !g.transparent) {
      reflective = j;
    }
  }
  coarse_points_.clear();
  for (int i = 0; i < scn->nlight; ++i) {
    const mjvLight& l = scn->lights[i];
    if (l.type != mjLIGHT_DIRECTIONAL)
      coarse_points_.insert(coarse_points_.end(), l.pos, l.pos + 3);
  }
  // The whole frame: clear, reflection, the maps, one lit pass, the skybox.
  float cam_project[16], cam_view[16];
  BeginFrame(viewport, *scn, *con, cam_project, cam_view);
  // The geoms' textures from one mipmap level (RenderOptions::nearest_mipmap), in the
  // reflection, the lit pass and the blended geoms; the skybox keeps MuJoCo's filter.
  BindSamplers(true);
  samplers_bound_ += sampler_2d_ != 0;
  std::copy_n(cam_project, 16, frame_project_.begin());
  std::copy_n(cam_view, 16, frame_view_.begin());
  DrawReflection(*scn, *con, reflective, head, cam_project, cam_view, transparent);

  std::vector<int> lights;  // shadow-casting lights, in map order
  for (int i = 0; i < scn->nlight; ++i) {
    if (Supported(scn->lights[i]) && scn->lights[i].castshadow) lights.push_back(i);
  }
  DrawMaps(*scn, *con, lights, fitted);

  gl.BindFramebuffer(GL_FRAMEBUFFER, con->offFBO);
  gl.DrawBuffer(GL_COLOR_ATTACHMENT0);
  gl.Viewport(viewport.left, viewport.bottom, viewport.width, viewport.height);
  gl.MatrixMode(GL_PROJECTION);
  gl.LoadMatrixf(cam_project);
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadMatrixf(cam_view);
  // The pass writes depth (mjr_render's: the same display lists under the same matrices).
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_GEQUAL);
  gl.DepthMask(GL_TRUE);
  const std::array<float, 16> inv_view = InverseRigid(cam_view);
  float eye_to_map[kMaxShadowLights][16] = {};
  for (size_t k = 0; k < lights.size(); ++k) {
    const std::array<float, 16> m = Mul(map_matrix_[k].data(), inv_view.data());
    std::memcpy(eye_to_map[k], m.data(), sizeof eye_to_map[k]);
  }
  for (int k = 0; k < kMaxShadowLights; ++k) {
    const size_t slot = std::min<size_t>(k, lights.size() - 1);
    gl.ActiveTexture(GL_TEXTURE0 + kUnitMap0 + k);
    gl.BindTexture(GL_TEXTURE_2D, map_tex_[slot]);
  }
  Programs programs(this, *scn, cam_view, lights, &eye_to_map[0][0]);
  // The order: geoms wholly on the camera's side of the reflective geom's plane first (the
  // plane cannot hide them, and its fragments behind them are then never shaded), the
  // reflective geom added over its reflection, then the rest (mjr_render draws the reflective
  // geom first: what is behind its plane stays hidden by it).
  std::vector<char> before(scn->ngeom, 0);
  if (reflective >= 0) {
    const mjvGeom& r = scn->geoms[reflective];
    float normal[3], origin[3];
    for (int i = 0; i < 3; ++i) {
      normal[i] = r.mat[3 * i + 2];
      origin[i] = r.pos[i] + (r.type == mjGEOM_BOX ? r.size[2] * normal[i] : 0.0f);
    }
    for (int j = 0; j < scn->ngeom; ++j) {
      const float radius = BoundingRadius(scn->geoms[j]);
      if (j == reflective || radius < 0 || scn->geoms[j].transparent) continue;
      float height = 0;
      for (int i = 0; i < 3; ++i) height += (scn->geoms[j].pos[i] - origin[i]) * normal[i];
      before[j] = height > radius;
    }
  }
  const ViewVolume view_volume = ViewVolumeOf(Mul(cam_project, cam_view).data());
  // Each opaque geom writes its id (0: none) as the alpha; the reflective geom adds its id to
  // the 0 its reflection left (the reflection writes no alpha).
  auto id_of = [&](const mjvGeom& g) -> int {
    if (ids == nullptr || g.objtype != mjOBJ_GEOM || g.objid < 0) return 0;
    const auto k = static_cast<size_t>(g.objid);
    return k < ids->size() ? (*ids)[k] : 0;
  };
  auto draw = [&](int j) {
    const mjvGeom& g = scn->geoms[j];
    if (LeftOut(view_volume, g)) return;
    SetGeom(gl, programs, g, *con, 1.0f, id_of(g));
    if (j == reflective) {
      gl.Enable(GL_BLEND);
      gl.BlendFunc(GL_ONE, GL_ONE);
    }
    DrawGeom(gl, g, *con, Coarse(g, head));
    if (j == reflective) gl.Disable(GL_BLEND);
  };
  // Nearest first, so that fewer hidden fragments are shaded.
  std::vector<std::pair<float, int>> front;
  {
    for (int j = 0; j < scn->ngeom; ++j) {
      if (!before[j]) continue;
      const float* p = scn->geoms[j].pos;
      front.emplace_back((p[0] - head[0]) * (p[0] - head[0]) + (p[1] - head[1]) * (p[1] - head[1]) +
                             (p[2] - head[2]) * (p[2] - head[2]),
                         j);
    }
    std::sort(front.begin(), front.end());
  }
  for (const auto& [distance, j] : front) draw(j);
  if (reflective >= 0) draw(reflective);
  for (int j = 0; j < scn->ngeom; ++j) {
    if (!before[j] && j != reflective && !scn->geoms[j].transparent) draw(j);
  }

  // No program, no texture left bound (the maps, the geoms' textures), unit 0 active.
  auto unbind = [&] {
    BindSamplers(false);
    gl.UseProgram(0);
    for (int t = kMaxShadowLights + kUnitMap0 - 1; t >= 0; --t) {
      gl.ActiveTexture(GL_TEXTURE0 + t);
      gl.BindTexture(GL_TEXTURE_2D, 0);
    }
    gl.ActiveTexture(GL_TEXTURE0 + kUnitCube);
    gl.BindTexture(GL_TEXTURE_CUBE_MAP, 0);
    gl.ActiveTexture(GL_TEXTURE0);
  };
  gl.DepthMask(GL_TRUE);
  unbind();
  gl.ColorMask(1, 1, 1, 0);  // the lit pass's ids stay
  DrawSkybox(*scn, *con, head);
  if (!transparent.empty()) {
    // As mjr_render last: the transparent geoms with every light, no shadows, blended.
    Programs blended(this, *scn, cam_view);
    BindSamplers(true);
    DrawBlended(gl, *scn, *con, blended, transparent, 1.0f);
    unbind();
  }
  gl.ColorMask(1, 1, 1, 1);
}

}  // namespace mlspaces::sim
