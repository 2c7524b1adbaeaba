// ShadowPass's shadow maps (shadow_pass.h): a depth render of the casters per shadow light,
// as mjr_render's shadow-map passes draw it, once per scene state.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "mlspaces/core/error.h"
#include "shadow_pass.h"
#include "shadow_pass_gl.h"

namespace mlspaces::sim {

using namespace detail;  // NOLINT(google-build-using-namespace): shadow_pass_gl.h's helpers

bool ShadowPass::ClosedMesh(int mesh) {
  if (mesh < 0 || mesh >= static_cast<int>(mesh_closed_.size())) return false;
  signed char& closed = mesh_closed_[static_cast<size_t>(mesh)];
  if (closed < 0) closed = MeshClosed(model_, mesh) ? 1 : 0;
  return closed == 1;
}

void ShadowPass::DrawMaps(const mjvScene& scn, const mjrContext& con,
                          const std::vector<int>& lights, bool fitted) {
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
  std::vector<float> key = {con.shadowClip,
                            con.shadowScale,
                            cam.frustum_near,
                            cam.frustum_far,
                            static_cast<float>(zero_to_one),
                            static_cast<float>(fitted)};
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

  // As mjr_render's shadow-map passes: depth only, flat, MuJoCo's offsets (no culling but
  // of the array below).
  gl.UseProgram(0);
  gl.Disable(GL_LIGHTING);
  gl.Disable(GL_BLEND);
  gl.ColorMask(0, 0, 0, 0);
  const bool cull_faces = gl.IsEnabled(GL_CULL_FACE);
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
  // Each map's matrices (MuJoCo's), and what its view volume holds. A map is drawn into the
  // viewport (1, 1, size - 2, size - 2), as mjr_render draws it (its outermost texels stay
  // empty), but mjr_render looks it up as if it filled the texture: a point at the square's
  // edge is looked up a texel away from where it was drawn. A fitted square's casters reach
  // its edges, and a lit slant surface there gets shadow acne (the wrist camera of
  // examples/pick_and_place's next_to lost 0.02 of SSIM to it), so a fitted directional map is
  // looked up where the point was drawn: x and y scaled by (size - 2) / size about the
  // centre. Elsewhere the lookup stays mjr_render's, for mjr_render's picture.
  const float inner = 0.5f * static_cast<float>(map_size_ - 2) / static_cast<float>(map_size_);
  float bias[16] = {0.5f, 0, 0, 0, 0, 0.5f, 0, 0, 0, 0, 1, 0, 0.5f, 0.5f, 0, 1};
  if (!zero_to_one) bias[10] = bias[14] = 0.5f;
  std::array<std::array<float, 16>, kMaxShadowLights> project{}, view_gl{};
  std::array<ViewVolume, kMaxShadowLights> volume{};
  for (size_t k = 0; k < lights.size(); ++k) {
    const mjvLight& l = scn.lights[lights[k]];
    float up[3];
    OrthoVec(up, l.dir);
    LoadReversedDepth(gl, zero_to_one);
    if (l.type == mjLIGHT_DIRECTIONAL) {
      gl.Ortho(-con.shadowClip, con.shadowClip, -con.shadowClip, con.shadowClip, cam.frustum_near,
               cam.frustum_far);
    } else {
      const double fovy = std::min<double>(2 * l.cutoff * con.shadowScale, 160);
      const double h =
          std::tan(static_cast<double>(static_cast<float>(fovy)) / 360.0 * mjPI) * cam.frustum_near;
      gl.Frustum(-h, h, -h, h, cam.frustum_near, cam.frustum_far);
    }
    gl.GetFloatv(GL_PROJECTION_MATRIX, project[k].data());
    gl.MatrixMode(GL_MODELVIEW);
    gl.LoadIdentity();
    const std::array<float, 16> view = LookAtMatrix(l.pos, l.dir, up);
    gl.MultMatrixf(view.data());
    gl.GetFloatv(GL_MODELVIEW_MATRIX, view_gl[k].data());
    const std::array<float, 16> clip = Mul(project[k].data(), view_gl[k].data());
    const bool exact = fitted && l.type == mjLIGHT_DIRECTIONAL;
    bias[0] = bias[5] = exact ? inner : 0.5f;
    map_matrix_[k] = Mul(bias, clip.data());
    volume[k] = ViewVolumeOf(clip.data());
  }
  // The casters in world coordinates, one array for every map of this state (those in no
  // map's view volume left out): a draw per geom costs more than its vertices on llvmpipe.
  // Other types keep their display lists. The array holds closed shapes only (MuJoCo's
  // builtins, outer faces counter-clockwise): along each ray from the light the nearest
  // surface is a face turned to the light, so a map culls the back faces (half the fill)
  // and keeps the same nearest depth, unless its near or far plane cuts a caster (a back
  // face may then be all that is left of it, as for a lamp inside its shade).
  casters_.clear();
  caster_indices_.clear();
  std::vector<int> listed;
  std::array<bool, kMaxShadowLights> cull{};
  cull.fill(true);
  auto cull_back_faces = [&] {
    gl.Enable(GL_CULL_FACE);
    gl.CullFace(GL_BACK);
    gl.FrontFace(GL_CCW);
    ++culled_draws_;
  };
  for (int j = 0; j < scn.ngeom; ++j) {
    const mjvGeom& g = scn.geoms[j];
    if (g.type == mjGEOM_LINE || g.category == mjCAT_DECOR) continue;
    const float radius = DrawnRadius(g, mesh_radius_);
    bool seen = false;
    for (size_t k = 0; k < lights.size() && !seen; ++k) seen = !Outside(volume[k], g.pos, radius);
    if (!seen) {
      left_out_ += static_cast<long long>(lights.size());
      continue;
    }
    if (!AppendWorldShape(*shapes_, g, &casters_, &caster_indices_)) {
      listed.push_back(j);
      continue;
    }
    for (size_t k = 0; k < lights.size(); ++k) {
      if (!Outside(volume[k], g.pos, radius) && !WithinDepth(volume[k], g.pos, radius)) {
        cull[k] = false;
      }
    }
  }
  gl.BindBuffer(GL_ARRAY_BUFFER, caster_buffer_);
  gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(casters_.size() * sizeof(float)),
                casters_.data(), GL_STREAM_DRAW);
  gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, caster_index_buffer_);
  gl.BufferData(GL_ELEMENT_ARRAY_BUFFER,
                static_cast<GLsizeiptr>(caster_indices_.size() * sizeof(unsigned int)),
                caster_indices_.data(), GL_STREAM_DRAW);
  gl.VertexPointer(3, GL_FLOAT, 0, nullptr);
  gl.BindBuffer(GL_ARRAY_BUFFER, 0);
  for (size_t k = 0; k < lights.size(); ++k) {
    gl.MatrixMode(GL_PROJECTION);
    gl.LoadMatrixf(project[k].data());
    gl.MatrixMode(GL_MODELVIEW);
    gl.LoadMatrixf(view_gl[k].data());
    gl.BindFramebuffer(GL_FRAMEBUFFER, map_fbo_[k]);
    gl.DrawBuffer(GL_NONE);
    gl.Viewport(0, 0, map_size_, map_size_);
    gl.Clear(GL_DEPTH_BUFFER_BIT);
    gl.Viewport(1, 1, map_size_ - 2, map_size_ - 2);
    if (cull[k] && !caster_indices_.empty()) cull_back_faces();
    gl.EnableClientState(GL_VERTEX_ARRAY);
    gl.DrawElements(GL_TRIANGLES, static_cast<GLsizei>(caster_indices_.size()), GL_UNSIGNED_INT,
                    nullptr);
    gl.DisableClientState(GL_VERTEX_ARRAY);
    gl.Disable(GL_CULL_FACE);  // meshes may be open: both sides, as mjr_render
    for (int j : listed) {
      const mjvGeom& g = scn.geoms[j];
      if (LeftOut(volume[k], g)) continue;
      // A closed mesh wholly between the near and far planes: its back faces too can go.
      const bool cull_mesh = g.type == mjGEOM_MESH && g.dataid >= 0 && g.dataid % 2 == 0 &&
                             ClosedMesh(g.dataid / 2) &&
                             WithinDepth(volume[k], g.pos, DrawnRadius(g, mesh_radius_));
      if (cull_mesh) cull_back_faces();
      DrawGeom(gl, g, con);
      if (cull_mesh) gl.Disable(GL_CULL_FACE);
    }
  }
  gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
  if (cull_faces) gl.Enable(GL_CULL_FACE);
  gl.Disable(GL_POLYGON_OFFSET_FILL);
  gl.Enable(GL_LIGHTING);
  gl.ColorMask(1, 1, 1, 1);
  map_key_ = std::move(key);
  ++map_renders_;
}

}  // namespace mlspaces::sim
