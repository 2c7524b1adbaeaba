// Headless offscreen rendering of a MuJoCo 3.5 model: RGB and metric depth from any camera
// pose, through OSMesa or EGL (Mesa's surfaceless platform, or the EGL device platform for a
// GPU), with no X server.
//
// The GL platform libraries are loaded at run time (dlopen), not linked: MuJoCo 3.5 takes its
// GL functions from the platform library it finds loaded in the process and prefers libEGL,
// so a process that has libEGL loaded cannot render through OSMesa. One process renders with
// one backend: the first Renderer fixes it, and a Renderer of the other backend in the same
// process throws Error.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

// MuJoCo's structs, declared as <mujoco/mujoco.h> declares them (include it to use them).
// NOLINTBEGIN(modernize-use-using): MuJoCo's own form of these declarations
struct mjModel_;
typedef struct mjModel_ mjModel;
struct mjData_;
typedef struct mjData_ mjData;
struct mjvScene_;
typedef struct mjvScene_ mjvScene;
struct mjvOption_;
typedef struct mjvOption_ mjvOption;
// NOLINTEND(modernize-use-using)

namespace mlspaces::sim {

enum class GlBackend { kOsMesa, kEgl };

/// "osmesa" -> kOsMesa, "egl" -> kEgl. @throws mlspaces::UsageError for any other name.
MLSPACES_API GlBackend ParseGlBackend(std::string_view name);
/// The backend a `flag` (e.g. "--gl") names with `value`, or when `value` is empty the
/// MLSPACES_GL environment variable's, else kOsMesa. @throws mlspaces::UsageError for a bad
/// name, prefixed with where it came from ("--gl: unknown GL backend ...", "MLSPACES_GL: ...").
MLSPACES_API GlBackend ResolveGlBackend(std::string_view value, std::string_view flag);
/// "osmesa" or "egl" (a static string: never dangles).
MLSPACES_API std::string_view GlBackendName(GlBackend backend);

/// The backend this process renders with: the one of the first Renderer that got as far as
/// MuJoCo's render context; nullopt before that.
MLSPACES_API std::optional<GlBackend> ProcessGlBackend();

/// Which EGL display an EGL Renderer uses: a device of EGL_EXT_platform_device (a GPU where a
/// driver exposes one, else Mesa's software device), or Mesa's surfaceless platform (llvmpipe).
enum class EglPlatform { kDevice, kSurfaceless };

// ============================================================================================
// EGL devices

/// One device of EGL_EXT_device_enumeration.
struct MLSPACES_API EglDevice {
  int index = 0;          ///< position in eglQueryDevicesEXT's list (MLSPACES_EGL_DEVICE's numbers)
  std::string name;       ///< the DRM device file, or "software" for Mesa's software device
  bool software = false;  ///< EGL_MESA_device_software (llvmpipe on the CPU)
};

/// The EGL devices, in the driver's order. Loads libEGL (so the process renders with EGL).
/// @throws Error when libEGL is missing or has no device enumeration.
MLSPACES_API std::vector<EglDevice> ListEglDevices();

/// The device that worker `worker` (0-based) of a pool renders on, as an index of
/// ListEglDevices(): MLSPACES_EGL_DEVICE when set, an index ("1") or a comma-separated list
/// that workers take in turn ("0,2,3"); unset, the hardware devices in turn (Mesa's software
/// device when there is none). @throws UsageError for a malformed MLSPACES_EGL_DEVICE or an
/// index past the devices (the message lists them); Error as ListEglDevices.
MLSPACES_API int ChooseEglDevice(int worker);

/// Declares this process worker `worker` of a pool (set by datagen's forked workers): a
/// Renderer on the device platform with egl_device < 0 takes ChooseEglDevice(worker).
/// Processes that never call it are worker 0.
MLSPACES_API void SetRenderWorker(int worker);

struct MLSPACES_API RenderOptions {
  int width = 640;
  int height = 368;
  GlBackend backend = GlBackend::kOsMesa;
  /// For backend kEgl only.
  EglPlatform egl_platform = EglPlatform::kDevice;
  /// For the device platform: an index of ListEglDevices(), or -1 for ChooseEglDevice(this
  /// process's worker), falling back to the other devices in turn when that one fails.
  int egl_device = -1;
  /// Capacity of the abstract scene (mjv_makeScene); geoms beyond it are not drawn.
  int max_geom = 10000;
  /// Side of the shadow maps in texels (the model's vis.quality.shadowsize when 0; MuJoCo's
  /// default is 4096). The shadow passes dominate a frame's cost: docs/sim.md has the curve.
  int shadow_size = 0;
  /// Multisampling of the offscreen buffer (the model's vis.quality.offsamples when -1;
  /// MuJoCo's default is 4); 0 turns it off.
  int multisamples = -1;
  /// Fit each frame's directional shadow maps to the shadow casters (FitShadowMaps in
  /// sim/shadow_fit.h), planes with nothing behind them no longer drawn into them. The maps
  /// keep the texel size that shadow_size gives on MuJoCo's square, so they shrink with the
  /// fitted square (measured on the model's initial state, plus a quarter): the same shadows
  /// for less work (docs/sim.md, "Render speed and quality"). false: MuJoCo's fixed square.
  bool fit_shadows = false;
  /// Draw the shadows in one pass (sim/shadow_pass.h): mjr_render's clear, reflection and
  /// skybox around one pass of the opaque geoms with every light and a map per shadow light,
  /// the maps drawn once per scene state (so shared by the cameras of one state). Scenes it
  /// cannot draw as mjr_render would (labels, fog, point lights, ...) go through
  /// mjr_render.
  bool one_pass_shadows = false;
  /// With one_pass_shadows: draw cylinders, capsule sides and boxes in fewer pieces along
  /// their straight sides (down to one stack or one quad a face) where each piece still spans
  /// at most 0.25 rad seen from the eye and from every positional light. The pieces cover
  /// the pixels MuJoCo's cover, with the same normals; only the per-vertex lighting along a
  /// side is sampled at fewer points. A frame of the tutorial costs about a fifth less on
  /// llvmpipe, at mean SSIM against full quality within 0.0001 of MuJoCo's shapes
  /// (docs/sim.md).
  bool coarse_sides = false;
  /// With one_pass_shadows: sample the geoms' textures from their nearest mipmap level
  /// (bilinear) instead of blending the two nearest (MuJoCo's trilinear filter). A
  /// tutorial frame, whose floor is textured, costs about 8% less on llvmpipe, at mean SSIM
  /// against full quality within 0.0004 of trilinear (docs/sim.md). Needs sampler objects
  /// (GL 3.3 or ARB_sampler_objects); without them, MuJoCo's filter.
  bool nearest_mipmap = false;
};

/// A camera in the world. `xmat` is MuJoCo's camera frame (as in mjData::cam_xmat): a
/// row-major 3x3 rotation whose columns are the camera's x (right), y (up) and z (backward)
/// axes in world coordinates; the camera looks along -z. `fovy_deg` is the vertical field of
/// view; the horizontal one follows from the image's aspect ratio.
struct MLSPACES_API CameraView {
  std::array<double, 3> pos{0, 0, 0};
  std::array<double, 9> xmat{1, 0, 0, 0, 1, 0, 0, 0, 1};
  double fovy_deg = 45;
};

/// A part of an image: `width` x `height` pixels from column `x`, row `y` (rows top down).
struct MLSPACES_API PixelRect {
  int x = 0, y = 0, width = 0, height = 0;
};

/// A camera at `eye` looking at `target`, world +z up in the image (when the view is
/// vertical, world +y is up in the image). @throws UsageError when eye == target.
MLSPACES_API CameraView LookAt(const std::array<double, 3>& eye,
                               const std::array<double, 3>& target, double fovy_deg = 45);

/// One GL context + mjrContext + mjvScene for one model. Not thread-safe: use a Renderer from
/// one thread at a time (one per worker). Several Renderers may live in one thread; Render()
/// makes its own context current.
class MLSPACES_API Renderer {
 public:
  // ===========================================================================================
  // Construction

  /// Renders `m` (shared, never modified: the Renderer keeps a private copy whose offscreen
  /// buffer is raised to width x height, so `m` need only live through the call; an mjData
  /// of `m` works with it).
  /// @throws UsageError for a non-positive size or max_geom; Error (one line) when the GL
  /// library is missing, no GL context can be made, MuJoCo cannot make its render context, or
  /// this process already renders with the other backend. Nothing leaks on failure.
  Renderer(const mjModel* m, RenderOptions options);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // ===========================================================================================
  // Rendering

  /// Renders the state in `d` (an mjData of the model given to the constructor, positions
  /// current, e.g. after mj_forward/mj_step) seen from `view`.
  /// `rgb`: height*width*3 bytes, rows top to bottom, written. `depth_m`: when not null,
  /// height*width floats, rows top to bottom: distance along the view axis (not along the
  /// ray) in metres; the far plane (m->vis.map.zfar * m->stat.extent) where nothing is hit.
  /// `d` is not changed, but MuJoCo uses its scratch stack while building the scene: do not
  /// render one mjData from two threads at once.
  /// @throws UsageError for a null d or rgb, or fovy_deg outside (0, 180).
  void Render(const mjData* d, const CameraView& view, unsigned char* rgb,
              float* depth_m = nullptr);

  /// The segmentation of the state in `d` seen from `view`: MuJoCo's mjRND_SEGMENT |
  /// mjRND_IDCOLOR render of the geoms Render draws (vis_option()'s groups), each flat, with
  /// no lights, textures, shadows, reflection or multisampling. `geom_ids`: height*width ints,
  /// rows top to bottom, written: the model geom id seen at each pixel, -1 where none is
  /// (background, sites, frames and other decor). Same conditions on `d` as Render().
  /// `interest` (may be null): per model geom id, non-zero for the geoms the caller needs;
  /// with one_pass_shadows only the part of the image where they may be seen is then drawn
  /// and read (every geom drawn there: what hides them still does) and the pixels outside it
  /// are -1 (none at all is drawn when they cannot be seen). Their pixels are always right.
  /// Returns the part drawn and read (the whole image, or empty when nothing was drawn):
  /// every pixel outside it is -1, so a reader may look inside it only.
  /// @throws UsageError for a null d or geom_ids, or fovy_deg outside (0, 180).
  PixelRect RenderSegmentation(const mjData* d, const CameraView& view, int* geom_ids,
                               const std::vector<unsigned char>* interest = nullptr);

  /// As RenderSegmentation(d, view, geom_ids, &interest) right after Render(d, view, ...),
  /// from that frame: where the frame carries the ids of `interest` (TrackGeoms with the
  /// same vector, none of them transparent) they are read from it, with nothing drawn; else
  /// only the geoms of interest are drawn, over the frame's depth, for about the
  /// price of drawing them alone. Either way each shows where it is the frame's nearest
  /// surface. Transparent geoms of interest show as in a segmentation; other transparent
  /// geoms (drawn blended, without depth) hide nothing, where a segmentation shows them in
  /// front. A frame not drawn by one pass (one_pass_shadows off, no shadows, a scene it
  /// cannot draw) or multisampled, or any other render since, takes RenderSegmentation
  /// instead. Only the pixels of the geoms of interest are meant (others may be -1). Returns
  /// the part read, as RenderSegmentation.
  /// @throws UsageError as RenderSegmentation.
  PixelRect SegmentLastFrame(const mjData* d, const CameraView& view, int* geom_ids,
                             const std::vector<unsigned char>& interest);

  /// The geoms whose pixels the frames to come carry for SegmentLastFrame (`interest`: per
  /// model geom id, non-zero to track; copied), until set again (empty: none). One pass
  /// writes each tracked geom's id into the frame's alpha as it draws the frame, so that
  /// SegmentLastFrame with this `interest` reads them instead of drawing the geoms again
  /// (the frame's colours and depth do not change). More than 255 geoms: none is tracked.
  void TrackGeoms(const std::vector<unsigned char>& interest);

  /// The views the renders to come show each state from (a camera system's cameras), for
  /// fit_shadows: each state's maps then hold the shadows any of them sees, and its renders
  /// share one set of maps. Without, a render's maps hold the shadows its own view sees.
  /// Kept until set again (empty: none). @throws UsageError for a fovy_deg outside (0, 180).
  void SetShadowViews(const std::vector<CameraView>& views);

  /// Renders camera `camera_id` of the model through MuJoCo's own fixed-camera path
  /// (mjCAMERA_FIXED); same outputs as Render(). Equals Render(d, ModelCamera(m, d, id), ...)
  /// up to float rounding. @throws UsageError for an id out of range.
  void RenderCamera(const mjData* d, int camera_id, unsigned char* rgb, float* depth_m = nullptr);

  /// The view of camera `camera_id` of the model: d->cam_xpos, d->cam_xmat, m->cam_fovy.
  /// @throws UsageError for an id out of range.
  static CameraView ModelCamera(const mjModel* m, const mjData* d, int camera_id);

  // ===========================================================================================
  // Access

  int width() const;
  int height() const;
  /// The Renderer's copy of the model (the offscreen buffer raised to the picture's size):
  /// its names, ids and structure are the model's. Owned by the Renderer, valid while it
  /// lives.
  const mjModel* model() const;
  GlBackend backend() const;
  /// The EGL device this Renderer renders on (an index of ListEglDevices()); -1 for OSMesa
  /// and the surfaceless platform.
  int egl_device() const;
  /// The side of the shadow maps in texels: shadow_size (or the model's), or with
  /// fit_shadows the side that gives that texel size on the fitted square.
  int shadow_size() const;
  /// With one_pass_shadows: how many times the shadow maps were drawn (once per scene state,
  /// whatever the cameras); 0 otherwise, and for frames rendered by mjr_render.
  long long shadow_map_renders() const;
  /// With one_pass_shadows: how many geom draws one pass left out because the geom lay wholly
  /// outside the view volume (of the camera, its reflection or a shadow map); 0 otherwise.
  long long one_pass_left_out() const;
  /// With one_pass_shadows and coarse_sides: how many geom draws (lit pass and reflection)
  /// used coarse sides; 0 otherwise.
  long long one_pass_coarse_draws() const;
  /// With one_pass_shadows: how many shadow-map draws culled the back faces (from the light)
  /// of closed shapes, which leaves the same nearest depth: the builtin shapes (one draw a
  /// map) and each closed mesh; 0 otherwise.
  long long one_pass_culled_draws() const;
  /// With one_pass_shadows and nearest_mipmap: how many frames sampled the geoms' textures
  /// from their nearest mipmap level (0 when the GL has no sampler objects); 0 otherwise.
  long long one_pass_nearest_mipmap_frames() const;
  /// Frames rendered so far, and of those the ones one pass drew (one_pass_shadows); the
  /// rest went through mjr_render (frames without shadows too: one pass saves nothing there).
  long long frames() const;
  long long one_pass_frames() const;
  /// How many SegmentLastFrame calls took the last frame (the others rendered), and of those
  /// how many read the ids it carried (TrackGeoms).
  long long frame_segmentations() const;
  long long tracked_segmentations() const;
  /// With one_pass_shadows: why the last frame with shadows that went through mjr_render
  /// could not be drawn in one pass ("a label ('floor')", "fog", ...); "" when none
  /// did.
  const std::string& one_pass_missed() const;
  /// The abstract scene: its flags (scene().flags[mjRND_SHADOW], mjRND_REFLECTION,
  /// mjRND_SKYBOX, ...) may be changed between renders. Owned by the Renderer, valid while
  /// it lives.
  mjvScene& scene();
  /// The visualisation options (geom groups, frames, ...) used by Render(). Owned by the
  /// Renderer, valid while it lives.
  mjvOption& vis_option();

  struct Impl;

 private:
  // The abstract scene of the state in `d` seen from `view`, the context current.
  void UpdateScene(const mjData* d, const CameraView& view);
  void Draw(unsigned char* rgb, float* depth_m);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces::sim
