#include "mlspaces/sim/renderer.h"

#ifndef GL_PACK_INVERT_MESA
#define GL_PACK_INVERT_MESA 0x8758
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "gl_context.h"
#include "mlspaces/core/error.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/shadow_fit.h"
#include "shadow_pass.h"

namespace mlspaces::sim {
namespace {

// Rows bottom up (mjr_readPixels) to top down, in place.
template <class T>
void FlipRows(T* pixels, int width, int height, int channels) {
  const size_t row = static_cast<size_t>(width) * channels;
  for (int top = 0, bottom = height - 1; top < bottom; ++top, --bottom) {
    std::swap_ranges(pixels + top * row, pixels + (top + 1) * row, pixels + bottom * row);
  }
}

}  // namespace

struct Renderer::Impl {
  RenderOptions options;
  int egl_device = -1;
  // Declared first, destroyed last: the MuJoCo objects below are freed with it current.
  std::optional<gl::Context> gl;
  ModelPtr model;  // private copy with a big enough offscreen buffer
  mjvOption opt{};
  mjvCamera cam{};
  mjvScene scn{};
  mjrContext con{};
  bool scene_made = false;
  bool context_made = false;
  float znear = 0, zfar = 0;
  // MuJoCo's shadow square, as mjr_makeContext sets mjrContext::shadowClip.
  float default_clip = 0;
  // RenderOptions::one_pass_shadows; its GL objects are freed before MuJoCo's.
  std::unique_ptr<ShadowPass> shadow_pass;
  // glPixelStorei when the driver reads rows top down (GL_MESA_pack_invert: Mesa's drivers),
  // which saves flipping them after mjr_readPixels; null otherwise.
  decltype(&::glPixelStorei) pack_invert = nullptr;
  long long frames = 0, one_pass_frames = 0;
  std::vector<ShadowView> shadow_views;    // SetShadowViews
  std::string one_pass_missed;             // why one pass could not draw the last frame it missed
  std::vector<unsigned char> segment_rgb;  // RenderSegmentation's colours
  std::vector<int> segment_table;          // and its colour -> geom id table
  // The last Render() was drawn by one pass and its buffer is as it left it (SegmentLastFrame).
  bool frame_in_buffer = false;
  long long frame_segmentations = 0, tracked_segmentations = 0;
  // TrackGeoms: its interest, per model geom the id the lit pass writes as alpha (1-255, 0:
  // none), per id the model geom (-1: none); empty when no geom is tracked.
  std::vector<unsigned char> track_interest, track_ids;
  std::array<int, 256> track_geom{};
  // The last frame as read with its alpha (rows top down), when it carries the tracked ids.
  std::vector<unsigned char> frame_rgba;
  bool frame_ids = false;

  ~Impl() {
    if (context_made && gl) {
      try {
        gl->MakeCurrent();
        shadow_pass.reset();
        mjr_freeContext(&con);
      } catch (...) {  // cannot make it current: leave the GL objects to the context's end
      }
    }
    if (scene_made) mjv_freeScene(&scn);
  }
};

namespace {

// The map side for fitted shadows: the texel size of a shadowsize² map over MuJoCo's square,
// on the square that fits the casters at the model's initial state plus a quarter for motion
// (FitShadowMaps fits each frame; the map size is fixed with the context). The casters are
// those whose shadows can fall in the box of the model's statistic (what cameras look at;
// bodies parked far away are not in it, sim::Scene::ExcludeFromStatistic).
int FittedShadowSize(const mjModel* m, Renderer::Impl& s) {
  const int full = m->vis.quality.shadowsize;
  const float default_clip = s.default_clip;
  DataPtr d = MakeData(m);
  mj_forward(m, d.get());
  mjv_updateScene(m, d.get(), &s.opt, nullptr, &s.cam, mjCAT_ALL, &s.scn);
  mjrContext probe;
  mjr_defaultContext(&probe);
  probe.shadowSize = full;
  // The statistic's box (centre +- extent / 2 on each axis) seen from above, orthographic.
  const double half = 0.5 * m->stat.extent;
  ShadowView box;
  box.camera.orthographic = 1;
  for (int k = 0; k < 3; ++k) box.camera.pos[k] = static_cast<float>(m->stat.center[k]);
  box.camera.pos[2] += static_cast<float>(2 * half);
  box.camera.forward[2] = -1;
  box.camera.up[1] = 1;
  box.camera.frustum_width = static_cast<float>(half);
  box.camera.frustum_bottom = static_cast<float>(-half);
  box.camera.frustum_top = static_cast<float>(half);
  box.camera.frustum_near = static_cast<float>(half);
  box.camera.frustum_far = static_cast<float>(3 * half);
  const ShadowFit fit = FitShadowMaps(m, &s.scn, &probe, default_clip, {box});
  if (!fit.fitted || !(default_clip > 0)) return full;
  const double share = std::min(1.0, 1.25 * fit.clip / default_clip);
  return std::max(64, static_cast<int>(std::ceil(full * share)));
}

}  // namespace

Renderer::Renderer(const mjModel* m, RenderOptions options) : impl_(std::make_unique<Impl>()) {
  InstallMujocoHandlers();
  if (m == nullptr) throw UsageError("Renderer: null model");
  if (options.width <= 0 || options.height <= 0) {
    throw UsageError("Renderer: image size must be positive, got " + std::to_string(options.width) +
                     "x" + std::to_string(options.height));
  }
  if (options.max_geom <= 0) throw UsageError("Renderer: max_geom must be positive");
  const GlBackend backend = options.backend;
  gl::CheckProcessBackend(backend);
  if (options.shadow_size < 0) {
    throw UsageError("Renderer: shadow_size must be >= 0 (0: the model's), got " +
                     std::to_string(options.shadow_size));
  }
  if (options.multisamples < -1) {
    throw UsageError("Renderer: multisamples must be >= -1 (-1: the model's), got " +
                     std::to_string(options.multisamples));
  }
  Impl& s = *impl_;
  s.options = options;
  s.egl_device = gl::MakeContext(options, s.gl);
  try {
    s.model.reset(mj_copyModel(nullptr, m));
    if (!s.model) gl::Fail(backend, "mj_copyModel failed");
    mjModel* mc = s.model.get();
    // The offscreen buffer of exactly the picture's size: a clear scissored to a part of the
    // buffer (mjr_render's and the one pass's) is a drawn quad on llvmpipe, a whole one a
    // memset, and the clears that are not scissored touch no unused rows.
    mc->vis.global.offwidth = options.width;
    mc->vis.global.offheight = options.height;
    if (options.shadow_size > 0) mc->vis.quality.shadowsize = options.shadow_size;
    if (options.multisamples >= 0) mc->vis.quality.offsamples = options.multisamples;
    s.znear = static_cast<float>(mc->vis.map.znear * mc->stat.extent);
    s.zfar = static_cast<float>(mc->vis.map.zfar * mc->stat.extent);

    mjv_defaultOption(&s.opt);
    mjv_defaultCamera(&s.cam);
    s.cam.type = mjCAMERA_FREE;
    mjv_defaultScene(&s.scn);
    s.scene_made = true;  // mjv_freeScene is safe on a default or partly made scene
    mjv_makeScene(mc, &s.scn, options.max_geom);
    s.default_clip = static_cast<float>(mc->stat.extent * mc->vis.map.shadowclip);
    if (options.fit_shadows) mc->vis.quality.shadowsize = FittedShadowSize(mc, s);

    mjr_defaultContext(&s.con);
    gl::ClaimProcessBackend(backend);
    s.context_made = true;  // mjr_freeContext frees whatever a failed make left
    mjr_makeContext(mc, &s.con, mjFONTSCALE_100);
    mjr_setBuffer(mjFB_OFFSCREEN, &s.con);
    if (s.con.currentBuffer != mjFB_OFFSCREEN || s.con.offWidth < options.width ||
        s.con.offHeight < options.height) {
      gl::Fail(backend, "MuJoCo has no " + std::to_string(options.width) + "x" +
                            std::to_string(options.height) + " offscreen buffer (got " +
                            std::to_string(s.con.offWidth) + "x" + std::to_string(s.con.offHeight) +
                            ")");
    }
    const GlProcLoader load = backend == GlBackend::kOsMesa ? &gl::OsMesaProc : &gl::EglProc;
    const auto get_string = reinterpret_cast<decltype(&::glGetString)>(load("glGetString"));
    const auto* extensions =
        get_string != nullptr ? reinterpret_cast<const char*>(get_string(GL_EXTENSIONS)) : nullptr;
    if (extensions != nullptr && std::strstr(extensions, "GL_MESA_pack_invert") != nullptr) {
      s.pack_invert = reinterpret_cast<decltype(&::glPixelStorei)>(load("glPixelStorei"));
    }
    if (options.one_pass_shadows) {
      try {
        s.shadow_pass =
            std::make_unique<ShadowPass>(load, mc, options.coarse_sides, options.nearest_mipmap);
      } catch (const Error& e) {
        gl::Fail(backend, std::string(e.what()) +
                              " (one_pass_shadows off, camera_config.one_pass_shadows: false in a"
                              " datagen config, renders with MuJoCo's own passes)");
      }
    }
  } catch (const MujocoError& e) {
    gl::Fail(backend, std::string("MuJoCo cannot make its render context: ") + e.what());
  }
}

Renderer::~Renderer() = default;

namespace {

void CheckFovy(const char* where, const CameraView& view) {
  if (!(view.fovy_deg > 0 && view.fovy_deg < 180)) {
    throw UsageError(std::string(where) + ": fovy_deg must be in (0, 180), got " +
                     std::to_string(view.fovy_deg));
  }
}

// `view` as mjv_updateCamera builds a fixed camera (one eye; mono rendering averages both):
// the near plane in double, then rounded to float. `c` keeps its other fields.
void SetGlCamera(const mjModel* m, const CameraView& view, float znear, float zfar,
                 mjvGLCamera* c) {
  const double top = m->vis.map.znear * m->stat.extent * std::tan(view.fovy_deg * mjPI / 360.0);
  for (int i = 0; i < 3; ++i) {
    c->pos[i] = static_cast<float>(view.pos[i]);
    c->forward[i] = static_cast<float>(-view.xmat[3 * i + 2]);
    c->up[i] = static_cast<float>(view.xmat[3 * i + 1]);
  }
  c->frustum_center = 0;
  c->frustum_top = static_cast<float>(top);
  c->frustum_bottom = static_cast<float>(-top);
  c->frustum_near = znear;
  c->frustum_far = zfar;
}

bool SameCamera(const mjvGLCamera& a, const mjvGLCamera& b) {
  return std::equal(a.pos, a.pos + 3, b.pos) && std::equal(a.forward, a.forward + 3, b.forward) &&
         std::equal(a.up, a.up + 3, b.up) && a.frustum_center == b.frustum_center &&
         a.frustum_width == b.frustum_width && a.frustum_bottom == b.frustum_bottom &&
         a.frustum_top == b.frustum_top && a.frustum_near == b.frustum_near &&
         a.frustum_far == b.frustum_far && a.orthographic == b.orthographic;
}

}  // namespace

void Renderer::SetShadowViews(const std::vector<CameraView>& views) {
  Impl& s = *impl_;
  std::vector<ShadowView> out;
  out.reserve(views.size());
  for (const CameraView& v : views) {
    CheckFovy("Renderer::SetShadowViews", v);
    ShadowView sv;
    SetGlCamera(s.model.get(), v, s.znear, s.zfar, &sv.camera);
    sv.aspect = static_cast<double>(s.options.width) / s.options.height;
    out.push_back(sv);
  }
  s.shadow_views = std::move(out);
}

void Renderer::Render(const mjData* d, const CameraView& view, unsigned char* rgb, float* depth_m) {
  if (d == nullptr || rgb == nullptr) throw UsageError("Renderer::Render: null data or rgb");
  CheckFovy("Renderer::Render", view);
  UpdateScene(d, view);
  Draw(rgb, depth_m);
}

namespace {

// Reads the segmentation colours of `part` of the offscreen buffer into geom_ids (width x
// height, top down; -1 outside `part`). Returns `part` top down.
PixelRect ReadSegmentation(Renderer::Impl& s, const mjrRect& part, int* geom_ids) {
  const int w = s.options.width, h = s.options.height;
  std::vector<unsigned char>& rgb = s.segment_rgb;
  rgb.resize(static_cast<size_t>(3) * part.width * part.height);
  if (s.pack_invert != nullptr) s.pack_invert(GL_PACK_INVERT_MESA, GL_TRUE);
  mjr_readPixels(rgb.data(), nullptr, part, &s.con);
  if (s.pack_invert != nullptr) {
    s.pack_invert(GL_PACK_INVERT_MESA, GL_FALSE);
  } else {
    FlipRows(rgb.data(), part.width, part.height, 3);
  }
  // Colour segid + 1 -> model geom id (-1: the clear colour, decor), by table.
  std::vector<int>& table = s.segment_table;
  table.assign(static_cast<size_t>(s.scn.ngeom) + 1, -1);
  for (int j = 0; j < s.scn.ngeom; ++j) {
    const mjvGeom& g = s.scn.geoms[j];
    if (g.objtype == mjOBJ_GEOM) table[static_cast<size_t>(j) + 1] = g.objid;
  }
  if (part.width != w || part.height != h) {
    std::fill(geom_ids, geom_ids + static_cast<size_t>(w) * h, -1);
  }
  const int top = h - (part.bottom + part.height);  // the part's first row, top down
  const unsigned char* c = rgb.data();
  for (int row = 0; row < part.height; ++row) {
    int* out = geom_ids + static_cast<size_t>(top + row) * w + part.left;
    for (int col = 0; col < part.width; ++col, c += 3) {
      const auto colour = static_cast<size_t>(c[0] | (c[1] << 8) | (c[2] << 16));
      out[col] = colour < table.size() ? table[colour] : -1;
    }
  }
  return {part.left, top, part.width, part.height};
}

}  // namespace

PixelRect Renderer::RenderSegmentation(const mjData* d, const CameraView& view, int* geom_ids,
                                       const std::vector<unsigned char>* interest) {
  Impl& s = *impl_;
  if (d == nullptr || geom_ids == nullptr) {
    throw UsageError("Renderer::RenderSegmentation: null data or geom_ids");
  }
  CheckFovy("Renderer::RenderSegmentation", view);
  UpdateScene(d, view);
  s.frame_in_buffer = false;
  const int w = s.options.width, h = s.options.height;
  const mjrRect viewport{0, 0, w, h};
  mjr_setBuffer(mjFB_OFFSCREEN, &s.con);
  // MuJoCo's segmentation: each geom flat in the colour of its index in the scene plus one
  // (mjRND_IDCOLOR), no lights, textures, shadows, reflection or multisampling; 0 is clear.
  // One pass draws it the same way with fewer vertices where it can, and only where the
  // geoms of interest may be.
  mjrRect part = viewport;
  if (s.shadow_pass && ShadowPass::SegmentUnsupported(s.scn) == nullptr) {
    if (interest != nullptr) part = s.shadow_pass->InterestRect(viewport, s.scn, *interest);
    if (part.width == 0) {
      std::fill(geom_ids, geom_ids + static_cast<size_t>(w) * h, -1);
      return {};
    }
    s.shadow_pass->Segment(viewport, s.scn, s.con, &part);
  } else {
    mjtByte* flags = s.scn.flags;
    const mjtByte segment = flags[mjRND_SEGMENT], idcolor = flags[mjRND_IDCOLOR];
    flags[mjRND_SEGMENT] = flags[mjRND_IDCOLOR] = 1;
    mjr_render(viewport, &s.scn, &s.con);
    flags[mjRND_SEGMENT] = segment;
    flags[mjRND_IDCOLOR] = idcolor;
  }
  return ReadSegmentation(s, part, geom_ids);
}

void Renderer::TrackGeoms(const std::vector<unsigned char>& interest) {
  Impl& s = *impl_;
  if (!s.track_ids.empty() && interest == s.track_interest) return;  // as it is
  s.track_interest.clear();
  s.track_ids.clear();
  s.track_geom.fill(-1);
  s.frame_ids = false;
  const int ngeom = s.model->ngeom;
  std::vector<unsigned char> ids(static_cast<size_t>(ngeom), 0);
  int next = 1;
  for (int g = 0; g < ngeom && static_cast<size_t>(g) < interest.size(); ++g) {
    if (interest[static_cast<size_t>(g)] == 0) continue;
    if (next > 255) return;  // more than the alpha can tell apart: none tracked
    s.track_geom[static_cast<size_t>(next)] = g;
    ids[static_cast<size_t>(g)] = static_cast<unsigned char>(next++);
  }
  if (next == 1) return;
  s.track_interest = interest;
  s.track_ids = std::move(ids);
}

PixelRect Renderer::SegmentLastFrame(const mjData* d, const CameraView& view, int* geom_ids,
                                     const std::vector<unsigned char>& interest) {
  Impl& s = *impl_;
  if (!s.frame_in_buffer || s.con.offSamples > 0) {
    return RenderSegmentation(d, view, geom_ids, &interest);
  }
  if (geom_ids == nullptr) throw UsageError("Renderer::SegmentLastFrame: null geom_ids");
  const int w = s.options.width, h = s.options.height;
  const mjrRect viewport{0, 0, w, h};
  const mjrRect part = s.shadow_pass->InterestRect(viewport, s.scn, interest);
  if (s.frame_ids && interest == s.track_interest &&
      !ShadowPass::TransparentOfInterest(s.scn, interest)) {
    // The frame's alpha holds the ids: nothing to draw; the frame stays.
    ++s.frame_segmentations;
    ++s.tracked_segmentations;
    if (part.width != w || part.height != h) {
      std::fill(geom_ids, geom_ids + static_cast<size_t>(w) * h, -1);
    }
    if (part.width == 0) return {};
    const int top = h - (part.bottom + part.height);  // the part's first row, top down
    for (int row = top; row < top + part.height; ++row) {
      const size_t first = static_cast<size_t>(row) * w + part.left;
      const unsigned char* c = s.frame_rgba.data() + 4 * first + 3;
      int* out = geom_ids + first;
      for (int col = 0; col < part.width; ++col, c += 4) out[col] = s.track_geom[*c];
    }
    return {part.left, top, part.width, part.height};
  }
  s.gl->MakeCurrent();
  s.frame_in_buffer = false;  // its colours are drawn over
  if (part.width == 0) {
    ++s.frame_segmentations;
    std::fill(geom_ids, geom_ids + static_cast<size_t>(w) * h, -1);
    return {};
  }
  s.shadow_pass->SegmentFrame(viewport, s.scn, s.con, interest, part);
  ++s.frame_segmentations;
  return ReadSegmentation(s, part, geom_ids);
}

void Renderer::UpdateScene(const mjData* d, const CameraView& view) {
  Impl& s = *impl_;
  s.gl->MakeCurrent();
  s.cam.type = mjCAMERA_FREE;
  // mjv_updateScene only uses d's scratch stack (restored before it returns).
  mjv_updateScene(s.model.get(), const_cast<mjData*>(d), &s.opt, nullptr, &s.cam, mjCAT_ALL,
                  &s.scn);
  // Replace the free camera by `view`: both eyes at the same place.
  for (mjvGLCamera& c : s.scn.camera) SetGlCamera(s.model.get(), view, s.znear, s.zfar, &c);
  // MuJoCo 3 places the headlight in mjv_updateScene, at the camera: move it with the view.
  for (int i = 0; i < s.scn.nlight; ++i) {
    mjvLight& l = s.scn.lights[i];
    if (!l.headlight) continue;
    for (int k = 0; k < 3; ++k) {
      l.pos[k] = static_cast<float>(view.pos[k]);
      l.dir[k] = static_cast<float>(-view.xmat[3 * k + 2]);
    }
  }
}

void Renderer::RenderCamera(const mjData* d, int camera_id, unsigned char* rgb, float* depth_m) {
  Impl& s = *impl_;
  if (d == nullptr || rgb == nullptr) {
    throw UsageError("Renderer::RenderCamera: null data or rgb");
  }
  if (camera_id < 0 || camera_id >= s.model->ncam) {
    throw UsageError("Renderer::RenderCamera: camera id " + std::to_string(camera_id) +
                     " out of range (the model has " + std::to_string(s.model->ncam) + " cameras)");
  }
  s.gl->MakeCurrent();
  s.cam.type = mjCAMERA_FIXED;
  s.cam.fixedcamid = camera_id;
  mjv_updateScene(s.model.get(), const_cast<mjData*>(d), &s.opt, nullptr, &s.cam, mjCAT_ALL,
                  &s.scn);
  Draw(rgb, depth_m);
}

void Renderer::Draw(unsigned char* rgb, float* depth_m) {
  Impl& s = *impl_;
  const int w = s.options.width, h = s.options.height;
  const mjrRect viewport{0, 0, w, h};
  mjr_setBuffer(mjFB_OFFSCREEN, &s.con);
  bool fitted = false;
  if (s.options.fit_shadows) {
    // The set views and this one (once), in the same order for every camera of a state.
    std::vector<ShadowView> views = s.shadow_views;
    const mjvGLCamera* eye = s.scn.camera;
    const ShadowView own{SameCamera(eye[0], eye[1]) ? eye[0] : mjv_averageCamera(eye, eye + 1),
                         static_cast<double>(w) / h};
    if (std::none_of(views.begin(), views.end(),
                     [&](const ShadowView& v) { return SameCamera(v.camera, own.camera); })) {
      views.push_back(own);
    }
    fitted = FitShadowMaps(s.model.get(), &s.scn, &s.con, s.default_clip, views).fitted;
  }
  ++s.frames;
  int geom = -1;
  const bool one_pass = s.shadow_pass && ShadowPass::HasShadows(s.scn, s.con);
  const char* missed = one_pass ? s.shadow_pass->Unsupported(s.scn, s.con, &geom) : nullptr;
  s.frame_in_buffer = one_pass && missed == nullptr;
  s.frame_ids = s.frame_in_buffer && !s.track_ids.empty() && s.con.offSamples == 0;
  if (s.frame_in_buffer) {
    s.shadow_pass->Render(viewport, &s.scn, &s.con, fitted, s.frame_ids ? &s.track_ids : nullptr);
    ++s.one_pass_frames;
  } else {
    if (missed != nullptr) {
      s.one_pass_missed = missed;
      const mjvGeom* g = geom >= 0 ? &s.scn.geoms[geom] : nullptr;
      if (g != nullptr && g->objtype == mjOBJ_GEOM) {
        const std::string name = MjName(s.model.get(), mjOBJ_GEOM, g->objid);
        s.one_pass_missed +=
            name.empty() ? " (geom " + std::to_string(g->objid) + ")" : " ('" + name + "')";
      }
    }
    mjr_render(viewport, &s.scn, &s.con);
  }
  if (s.pack_invert != nullptr) s.pack_invert(GL_PACK_INVERT_MESA, GL_TRUE);
  const size_t count = static_cast<size_t>(w) * h;
  if (s.frame_ids) {
    // RGBA, the ids kept for SegmentLastFrame: as cheap to read as RGB.
    s.frame_rgba.resize(4 * count);
    s.con.readPixelFormat = GL_RGBA;
    mjr_readPixels(s.frame_rgba.data(), depth_m, viewport, &s.con);
    s.con.readPixelFormat = GL_RGB;
    if (s.pack_invert == nullptr) FlipRows(s.frame_rgba.data(), w, h, 4);
    const unsigned char* in = s.frame_rgba.data();
    unsigned char* out = rgb;
    for (size_t i = 0; i < count; ++i, in += 4, out += 3) {
      out[0] = in[0];
      out[1] = in[1];
      out[2] = in[2];
    }
  } else {
    mjr_readPixels(rgb, depth_m, viewport, &s.con);
  }
  if (s.pack_invert != nullptr) {
    s.pack_invert(GL_PACK_INVERT_MESA, GL_FALSE);
  } else if (!s.frame_ids) {
    FlipRows(rgb, w, h, 3);
  }
  if (depth_m != nullptr) {
    // Nonlinear [0,1] depth buffer -> distance along the view axis (platform.md, "Depth").
    const double n = s.znear, ratio = 1.0 - static_cast<double>(s.znear) / s.zfar;
    for (size_t i = 0; i < count; ++i) {
      depth_m[i] = static_cast<float>(n / (1.0 - depth_m[i] * ratio));
    }
    if (s.pack_invert == nullptr) FlipRows(depth_m, w, h, 1);
  }
}

CameraView LookAt(const std::array<double, 3>& eye, const std::array<double, 3>& target,
                  double fovy_deg) {
  // z (backward) = eye - target; x (right) = world up x z; y (up) = z x x.
  mjtNum z[3] = {eye[0] - target[0], eye[1] - target[1], eye[2] - target[2]};
  if (mju_normalize3(z) < mjMINVAL) throw UsageError("LookAt: eye and target coincide");
  mjtNum up[3] = {0, 0, 1};
  if (std::abs(z[2]) > 1 - 1e-9) {  // vertical view: world +y up in the image
    up[1] = 1;
    up[2] = 0;
  }
  mjtNum x[3], y[3];
  mju_cross(x, up, z);
  mju_normalize3(x);
  mju_cross(y, z, x);
  CameraView v;
  v.pos = eye;
  for (int i = 0; i < 3; ++i) {
    v.xmat[3 * i + 0] = x[i];
    v.xmat[3 * i + 1] = y[i];
    v.xmat[3 * i + 2] = z[i];
  }
  v.fovy_deg = fovy_deg;
  return v;
}

CameraView Renderer::ModelCamera(const mjModel* m, const mjData* d, int camera_id) {
  if (m == nullptr || d == nullptr) throw UsageError("Renderer::ModelCamera: null model or data");
  if (camera_id < 0 || camera_id >= m->ncam) {
    throw UsageError("Renderer::ModelCamera: camera id " + std::to_string(camera_id) +
                     " out of range (the model has " + std::to_string(m->ncam) + " cameras)");
  }
  CameraView v;
  std::copy_n(d->cam_xpos + 3 * camera_id, 3, v.pos.begin());
  std::copy_n(d->cam_xmat + 9 * camera_id, 9, v.xmat.begin());
  v.fovy_deg = m->cam_fovy[camera_id];
  return v;
}

int Renderer::width() const { return impl_->options.width; }
int Renderer::height() const { return impl_->options.height; }
const mjModel* Renderer::model() const { return impl_->model.get(); }
GlBackend Renderer::backend() const { return impl_->options.backend; }
int Renderer::egl_device() const { return impl_->egl_device; }
int Renderer::shadow_size() const { return impl_->con.shadowSize; }
long long Renderer::frames() const { return impl_->frames; }
long long Renderer::one_pass_frames() const { return impl_->one_pass_frames; }
long long Renderer::frame_segmentations() const { return impl_->frame_segmentations; }
long long Renderer::tracked_segmentations() const { return impl_->tracked_segmentations; }
const std::string& Renderer::one_pass_missed() const { return impl_->one_pass_missed; }
long long Renderer::shadow_map_renders() const {
  return impl_->shadow_pass ? impl_->shadow_pass->map_renders() : 0;
}
long long Renderer::one_pass_left_out() const {
  return impl_->shadow_pass ? impl_->shadow_pass->left_out() : 0;
}
long long Renderer::one_pass_coarse_draws() const {
  return impl_->shadow_pass ? impl_->shadow_pass->coarse_draws() : 0;
}
long long Renderer::one_pass_culled_draws() const {
  return impl_->shadow_pass ? impl_->shadow_pass->culled_draws() : 0;
}
long long Renderer::one_pass_nearest_mipmap_frames() const {
  return impl_->shadow_pass ? impl_->shadow_pass->samplers_bound() : 0;
}
mjvScene& Renderer::scene() { return impl_->scn; }
mjvOption& Renderer::vis_option() { return impl_->opt; }

}  // namespace mlspaces::sim
