// The segmentation pass of ShadowPass: MuJoCo's mjRND_SEGMENT | mjRND_IDCOLOR picture drawn
// with the one pass's culling and coarse sides, optionally in part of the image only.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "shadow_pass.h"
#include "shadow_pass_gl.h"

namespace mlspaces::sim {

using namespace detail;  // NOLINT(google-build-using-namespace): the pass's own helpers

const char* ShadowPass::SegmentUnsupported(const mjvScene& scn) {
  if (scn.stereo != mjSTEREO_NONE) return "stereo";
  if (scn.framewidth > 0) return "a frame";
  if (scn.enabletransform) return "a scene transform";
  if (scn.nskin > 0) return "skins";
  for (int i = 0; i < scn.ngeom; ++i) {
    if (!DrawnType(scn.geoms[i].type)) return "a geom type it does not draw";
  }
  return nullptr;
}

namespace {

// The clip matrix of `part` of `viewport`: its normalised coordinates mapped onto [-1, 1].
std::array<float, 16> PartClip(const mjrRect& viewport, const mjrRect& part, const float* clip) {
  const float a = 2.0f * static_cast<float>(part.left - viewport.left) / viewport.width - 1;
  const float b = a + 2.0f * static_cast<float>(part.width) / viewport.width;
  const float c = 2.0f * static_cast<float>(part.bottom - viewport.bottom) / viewport.height - 1;
  const float d = c + 2.0f * static_cast<float>(part.height) / viewport.height;
  const float to_part[16] = {2 / (b - a), 0, 0, 0, 0, 2 / (d - c),        0,
                             0,           0, 0, 1, 0, -(a + b) / (b - a), -(c + d) / (d - c),
                             0,           1};
  return Mul(to_part, clip);
}

// Draws `g` flat in mjr_render's segmentation colour: segid + 1, red the low byte.
void DrawIdColour(const ShadowPass::Gl& gl, const mjvGeom& g, const mjrContext& con,
                  const CoarseLevel* coarse) {
  const unsigned id = static_cast<unsigned>(g.segid) + 1;
  gl.Color4f(static_cast<float>(id & 0xFF) / 255.0f, static_cast<float>((id >> 8) & 0xFF) / 255.0f,
             static_cast<float>((id >> 16) & 0xFF) / 255.0f, 1.0f);
  DrawGeom(gl, g, con, coarse);
}

// Whether `g` is a model geom that `interest` marks.
bool OfInterest(const mjvGeom& g, const std::vector<unsigned char>& interest) {
  return g.objtype == mjOBJ_GEOM && g.objid >= 0 &&
         static_cast<size_t>(g.objid) < interest.size() &&
         interest[static_cast<size_t>(g.objid)] != 0;
}

// mjr_render's segmentation state: constant colours, no lights, textures or multisampling
// (FlatColours); and back to the lit state the other passes expect (LitColours).
void FlatColours(const ShadowPass::Gl& gl) {
  gl.Disable(GL_LIGHTING);
  gl.Disable(GL_COLOR_MATERIAL);
  gl.Disable(GL_MULTISAMPLE);
  gl.Disable(GL_TEXTURE_2D);
}
void LitColours(const ShadowPass::Gl& gl) {
  gl.Disable(GL_SCISSOR_TEST);
  gl.Enable(GL_LIGHTING);
  gl.Enable(GL_COLOR_MATERIAL);
}

}  // namespace

void ShadowPass::SegmentFrame(const mjrRect& viewport, const mjvScene& scn, const mjrContext& con,
                              const std::vector<unsigned char>& interest, const mjrRect& part) {
  Gl& gl = *gl_;
  float head[3];
  HeadPos(scn, head);  // with the frame's lights (coarse_points_): the lit pass's pieces
  gl.BindFramebuffer(GL_FRAMEBUFFER, con.offFBO);
  gl.DrawBuffer(GL_COLOR_ATTACHMENT0);
  gl.UseProgram(0);
  gl.Viewport(viewport.left, viewport.bottom, viewport.width, viewport.height);
  gl.Scissor(part.left, part.bottom, part.width, part.height);
  gl.Enable(GL_SCISSOR_TEST);
  gl.ClearColor(0, 0, 0, 0);
  gl.Clear(GL_COLOR_BUFFER_BIT);
  gl.MatrixMode(GL_PROJECTION);
  gl.LoadMatrixf(frame_project_.data());
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadMatrixf(frame_view_.data());
  FlatColours(gl);
  gl.Disable(GL_BLEND);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_GEQUAL);  // nothing is nearer than the frame's surface: equal passes
  gl.DepthMask(GL_FALSE);
  const std::array<float, 16> clip = Mul(frame_project_.data(), frame_view_.data());
  const ViewVolume volume = ViewVolumeOf(PartClip(viewport, part, clip.data()).data());
  // The opaque geoms of interest first, then the transparent ones, which the frame drew
  // without depth: where they are nearer than its surface, the nearest of them, as in a
  // segmentation (which draws them opaque). Writing depth spends the frame (frame_in_buffer).
  for (const bool transparent : {false, true}) {
    if (transparent) gl.DepthMask(GL_TRUE);
    for (int j = 0; j < scn.ngeom; ++j) {
      const mjvGeom& g = scn.geoms[j];
      if (g.segid < 0 || static_cast<bool>(g.transparent) != transparent ||
          !OfInterest(g, interest) || LeftOut(volume, g)) {
        continue;
      }
      DrawIdColour(gl, g, con, Coarse(g, head));
    }
  }
  LitColours(gl);
}

bool ShadowPass::TransparentOfInterest(const mjvScene& scn,
                                       const std::vector<unsigned char>& interest) {
  for (int j = 0; j < scn.ngeom; ++j) {
    if (scn.geoms[j].transparent && OfInterest(scn.geoms[j], interest)) return true;
  }
  return false;
}

mjrRect ShadowPass::InterestRect(const mjrRect& viewport, const mjvScene& scn,
                                 const std::vector<unsigned char>& interest) const {
  const mjvGLCamera cam = mjv_averageCamera(scn.camera, scn.camera + 1);
  const double height = cam.frustum_top - cam.frustum_bottom;
  const double halfwidth =
      cam.frustum_width ? cam.frustum_width : 0.5 * viewport.width / viewport.height * height;
  double right[3];
  right[0] = cam.forward[1] * cam.up[2] - cam.forward[2] * cam.up[1];
  right[1] = cam.forward[2] * cam.up[0] - cam.forward[0] * cam.up[2];
  right[2] = cam.forward[0] * cam.up[1] - cam.forward[1] * cam.up[0];
  // Bounds in normalised device coordinates, x then y.
  double lo[2] = {2, 2}, hi[2] = {-2, -2};
  for (int j = 0; j < scn.ngeom; ++j) {
    const mjvGeom& g = scn.geoms[j];
    if (!OfInterest(g, interest)) continue;
    const double r = DrawnRadius(g, mesh_radius_);
    double v[3], depth = 0, along[2] = {0, 0};
    for (int k = 0; k < 3; ++k) v[k] = g.pos[k] - cam.pos[k];
    for (int k = 0; k < 3; ++k) {
      depth += v[k] * cam.forward[k];
      along[0] += v[k] * right[k];
      along[1] += v[k] * cam.up[k];
    }
    if (depth + r < cam.frustum_near || depth - r > cam.frustum_far) continue;  // out of view
    if (r < 0 || (!cam.orthographic && depth - r <= 0.5 * cam.frustum_near)) return viewport;
    // The sphere within its box in camera coordinates; x / depth is extreme at its corners.
    const double scale[2] = {cam.frustum_near / halfwidth, 2 * cam.frustum_near / height};
    const double shift[2] = {cam.frustum_center / halfwidth,
                             (cam.frustum_top + cam.frustum_bottom) / height};
    for (int a = 0; a < 2; ++a) {
      const double low = along[a] - r, high = along[a] + r;
      double l, h;
      if (cam.orthographic) {
        l = low * (a == 0 ? 1 / halfwidth : 2 / height) - shift[a];
        h = high * (a == 0 ? 1 / halfwidth : 2 / height) - shift[a];
      } else {
        l = scale[a] * low / (low < 0 ? depth - r : depth + r) - shift[a];
        h = scale[a] * high / (high > 0 ? depth - r : depth + r) - shift[a];
      }
      lo[a] = std::min(lo[a], l);
      hi[a] = std::max(hi[a], h);
    }
  }
  mjrRect out{viewport.left, viewport.bottom, 0, 0};
  if (lo[0] >= 1 || hi[0] <= -1 || lo[1] >= 1 || hi[1] <= -1) return out;  // none in view
  auto pixel = [](double ndc, int size) { return 0.5 * (ndc + 1) * size; };
  const int x0 = std::max(0, static_cast<int>(std::floor(pixel(lo[0], viewport.width))) - 1);
  const int x1 =
      std::min(viewport.width, static_cast<int>(std::ceil(pixel(hi[0], viewport.width))) + 1);
  const int y0 = std::max(0, static_cast<int>(std::floor(pixel(lo[1], viewport.height))) - 1);
  const int y1 =
      std::min(viewport.height, static_cast<int>(std::ceil(pixel(hi[1], viewport.height))) + 1);
  if (x1 <= x0 || y1 <= y0) return out;
  return {viewport.left + x0, viewport.bottom + y0, x1 - x0, y1 - y0};
}

void ShadowPass::Segment(const mjrRect& viewport, const mjvScene& scn, const mjrContext& con,
                         const mjrRect* part) {
  Gl& gl = *gl_;
  float head[3];
  HeadPos(scn, head);
  coarse_points_.clear();  // unlit: the pieces need only span little seen from the eye
  float cam_project[16], cam_view[16];
  BeginFrame(viewport, scn, con, cam_project, cam_view);
  FlatColours(gl);
  std::array<float, 16> clip = Mul(cam_project, cam_view);
  if (part != nullptr) {
    gl.Scissor(part->left, part->bottom, part->width, part->height);
    gl.Enable(GL_SCISSOR_TEST);
    clip = PartClip(viewport, *part, clip.data());
  }
  const ViewVolume view_volume = ViewVolumeOf(clip.data());
  for (int j = 0; j < scn.ngeom; ++j) {
    const mjvGeom& g = scn.geoms[j];
    if (g.segid < 0 || LeftOut(view_volume, g)) continue;
    DrawIdColour(gl, g, con, Coarse(g, head));
  }
  LitColours(gl);
}

}  // namespace mlspaces::sim
