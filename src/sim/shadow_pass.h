#pragma once
// Shadows in one pass, for the Renderer (RenderOptions::one_pass_shadows).
//
// MuJoCo's mjr_render draws the scene twice more for each shadow-casting light (its shadow
// map, then the scene lit by that light alone, added on top), for every camera. ShadowPass
// renders the same picture with fewer passes and no mjr_render: mjr_render's clear and
// reflection (the mirrored scene through the stencil), then one pass over the opaque geoms
// whose shader computes MuJoCo's fixed-function lighting per light and looks each shadow
// light up in its own map, then mjr_render's skybox and haze, then the transparent geoms
// blended with every light (mjr_render's order). The maps are drawn once per
// scene state, so the cameras of one state share them. A geom wholly outside the view volume
// of a pass (the camera, its reflection, a map) is left out of it: the GL would clip away
// all it draws, after transforming its vertices.
#include <mujoco/mujoco.h>

#include <array>
#include <map>
#include <memory>
#include <vector>

namespace mlspaces::sim {
namespace detail {
struct CoarseSides;
struct CoarseLevel;
struct IndexedShapes;
}  // namespace detail

/// A GL function by name (OSMesaGetProcAddress, eglGetProcAddress); null when missing.
using GlProcLoader = void* (*)(const char* name);

struct BuiltinShapes;

class ShadowPass {
 public:
  /// Loads the GL functions and compiles the shader, with the GL context current.
  /// @throws Error (one line) when a function is missing or the shader does not build.
  /// `m`: the model the scenes come from (its vis.quality shapes the builtin geoms); it must
  /// outlive the pass (its meshes are read when first drawn into a map).
  /// `coarse_sides` and `nearest_mipmap`: RenderOptions' (nearest_mipmap needs sampler
  /// objects, GL 3.3 or ARB_sampler_objects; without them the textures keep MuJoCo's
  /// trilinear filter: see samplers_bound()).
  ShadowPass(GlProcLoader load, const mjModel* m, bool coarse_sides = false,
             bool nearest_mipmap = false);
  /// Frees the GL objects: the context must be current (or gone, with the objects).
  ~ShadowPass();
  ShadowPass(const ShadowPass&) = delete;
  ShadowPass& operator=(const ShadowPass&) = delete;

  /// Whether mjr_render would draw shadows in `scn`: shadows on, a shadow map, a light that
  /// casts shadows. Without, one pass has nothing to save.
  static bool HasShadows(const mjvScene& scn, const mjrContext& con);
  /// Why Render cannot draw `scn` as mjr_render would, or null when it can: shadows
  /// (HasShadows), at most four shadow-casting lights, at most eight lights, only directional
  /// and spot lights, no plane seen from behind, no label, fog, segmentation, wireframe,
  /// stereo, frame, scene transform or skin, and only geom types it draws (planes, height
  /// fields, spheres, capsules, ellipsoids, cylinders, boxes, meshes). `geom` (may be null)
  /// gets the geom the reason is about, or -1. When not null, the caller renders with
  /// mjr_render. The text is static.
  const char* Unsupported(const mjvScene& scn, const mjrContext& con, int* geom) const;

  /// Renders `scn` (Unsupported() null) into `con`'s current buffer, as mjr_render(viewport,
  /// scn, con) with its shadows. `scn` is modified as mjr_render modifies it. `fitted`: the
  /// directional lights' squares were fitted to the casters (FitShadowMaps), which reach the
  /// squares' edges; their maps are then looked up where mjr_render drew them, not as
  /// mjr_render looks them up, a texel off at the edges (see DrawMaps).
  /// The buffer's alpha is left holding which geom each pixel shows, for the geoms `ids`
  /// marks (per model geom id, 1-255; ids past its end and 0 are none; null: none): the id
  /// where the lit pass drew the geom as the nearest surface, 0 elsewhere (other geoms, the
  /// background; transparent geoms, the reflection and the skybox write no alpha).
  void Render(const mjrRect& viewport, mjvScene* scn, const mjrContext* con, bool fitted = false,
              const std::vector<unsigned char>* ids = nullptr);

  /// Why Segment cannot draw `scn` as mjr_render draws it with mjRND_SEGMENT and
  /// mjRND_IDCOLOR, or null when it can: a geom type it does not draw, skins, stereo, a frame
  /// or a scene transform. The text is static.
  static const char* SegmentUnsupported(const mjvScene& scn);
  /// Renders the segmentation of `scn` (SegmentUnsupported() null) into `con`'s current
  /// buffer, as mjr_render with mjRND_SEGMENT and mjRND_IDCOLOR: each geom whose segid is
  /// >= 0 in the flat colour segid + 1 (red the low byte), unlit, untextured, without
  /// multisampling, over a clear of 0, in the scene's order. The geoms wholly outside the view
  /// volume are left out, and coarse sides (which cover the same pixels) used where the pass
  /// has them. `part` (may be null: all of `viewport`): only its pixels are drawn, the geoms
  /// wholly outside it left out.
  void Segment(const mjrRect& viewport, const mjvScene& scn, const mjrContext& con,
               const mjrRect* part = nullptr);
  /// Draws over the frame Render() last drew into `con`'s buffer (same `viewport` and `scn`,
  /// its depth buffer untouched since) the geoms whose model geom id `interest` marks, each
  /// in the colour segid + 1 where it is the frame's nearest surface, over a clear of 0 in
  /// `part` alone: the segmentation of those geoms (Segment's, where no transparent geom
  /// outside `interest` is in front) for the price of drawing them. Transparent geoms of
  /// interest write depth: the frame's depth is spent. The frame must not be multisampled.
  void SegmentFrame(const mjrRect& viewport, const mjvScene& scn, const mjrContext& con,
                    const std::vector<unsigned char>& interest, const mjrRect& part);
  /// The part of `viewport` where the geoms of `scn` whose model geom id `interest` marks
  /// (non-zero; ids past its end are not marked) may be seen, from the camera of `scn` and the
  /// geoms' drawn bounding spheres, with a pixel to spare; width 0 when none can be (all
  /// behind the camera or outside the view), all of `viewport` when one crosses the near plane
  /// or is unbounded (a plane, a height field).
  mjrRect InterestRect(const mjrRect& viewport, const mjvScene& scn,
                       const std::vector<unsigned char>& interest) const;
  /// Whether a geom of `scn` that `interest` marks is transparent (mjvGeom::transparent as
  /// the last Render() set it): drawn blended, it leaves no id in the frame's alpha.
  static bool TransparentOfInterest(const mjvScene& scn,
                                    const std::vector<unsigned char>& interest);

  /// How many times the maps were drawn (a state seen by two cameras draws them once).
  long long map_renders() const { return map_renders_; }
  /// How many geom draws were left out, the geom being wholly outside the view volume of
  /// the camera, its reflection or a map (what it would draw is clipped away).
  long long left_out() const { return left_out_; }
  /// How many geom draws of the lit pass and the reflection used coarse sides.
  long long coarse_draws() const { return coarse_draws_; }
  /// How many Render() calls sampled the geoms' textures from their nearest mipmap level
  /// (RenderOptions::nearest_mipmap with sampler objects).
  long long samplers_bound() const { return samplers_bound_; }
  /// How many map draws culled back faces: the array of builtin shapes (once per map) and
  /// each closed mesh (see DrawMaps).
  long long culled_draws() const { return culled_draws_; }

  struct Gl;
  /// One pass's programs (one per texture mode, given the pass's lights on first use), and
  /// a program's per-geom uniform locations: shadow_pass.cc's own.
  struct Programs;
  struct GeomUniforms;
  /// A built program and its uniform locations (looked up once, at link time).
  struct BuiltProgram;

 private:
  // Whether `g` is wholly outside `volume` (counted in left_out_).
  bool LeftOut(const std::array<std::array<float, 4>, 6>& volume, const mjvGeom& g);
  // The shader program for nlight lights of which nmap cast shadows, for geoms of texture
  // mode `texmode` (GeomTexture::mode), built on first use (its samplers bound to their
  // texture units then); valid while the pass lives.
  const BuiltProgram& Program(int nlight, int nmap, int texmode);

  // mjr_render's skybox and haze behind what the pass drew (none without a skybox texture),
  // around the eye at `head` (HeadPos).
  void DrawSkybox(const mjvScene& scn, const mjrContext& con, const float* head);
  // Binds (or, `on` false, unbinds) the nearest-mipmap samplers on the geoms' texture units,
  // when the pass has them.
  void BindSamplers(bool on);
  // mjr_render's GL state, clear and camera; the camera's matrices out.
  void BeginFrame(const mjrRect& viewport, const mjvScene& scn, const mjrContext& con,
                  float* cam_project, float* cam_view);
  // mjr_render's reflection of the scene in the reflective geom (index, -1 for none), seen
  // from the eye at `head` (HeadPos).
  void DrawReflection(const mjvScene& scn, const mjrContext& con, int reflective, const float* head,
                      const float* cam_project, const float* cam_view,
                      const std::vector<int>& transparent);
  // The light uniforms of `program` (current) under the modelview `view`; shadow_lights get
  // map slots.
  void SetLights(const BuiltProgram& program, const mjvScene& scn, const float* view,
                 const std::vector<int>& shadow_lights);
  void DrawMaps(const mjvScene& scn, const mjrContext& con, const std::vector<int>& lights,
                bool fitted);
  // MeshClosed for mesh `mesh` of the model, found on first use.
  bool ClosedMesh(int mesh);
  // The coarse sides to draw `g` with, seen from `eye` (and the positional lights of the
  // frame); null for MuJoCo's display lists. Counted in coarse_draws_.
  const detail::CoarseLevel* Coarse(const mjvGeom& g, const float* eye);
  std::unique_ptr<Gl> gl_;
  std::unique_ptr<detail::IndexedShapes> shapes_;
  unsigned int caster_buffer_ = 0;
  unsigned int caster_index_buffer_ = 0;
  // Coarse sides for the lit pass and the reflection (null: MuJoCo's lists only), and the
  // frame's positional lights (x y z each) that choose them with the eye.
  std::unique_ptr<detail::CoarseSides> coarse_;
  std::vector<float> coarse_points_;
  // The geoms' samplers (RenderOptions::nearest_mipmap): 2D textures on kUnit2d, cube
  // textures on kUnitCube, with MuJoCo's wrap modes; 0 for none.
  unsigned int sampler_2d_ = 0;
  unsigned int sampler_cube_ = 0;
  std::array<float, 16> frame_project_{}, frame_view_{};  // the last Render()'s matrices
  std::vector<float> mesh_radius_;  // per mesh: the largest distance of a vertex from its frame
  const mjModel* model_ = nullptr;
  std::vector<signed char> mesh_closed_;  // per mesh: -1 not yet known, else MeshClosed
  std::vector<float> casters_;  // the maps' casters in world coordinates (x y z per vertex)
  std::vector<unsigned int> caster_indices_;  // their triangles
  std::map<int, std::unique_ptr<BuiltProgram>> programs_;
  std::array<unsigned int, 4> map_tex_{};
  std::array<unsigned int, 4> map_fbo_{};
  int map_size_ = 0;
  // Light-space matrices of the maps (bias * projection * view, column-major).
  std::array<std::array<float, 16>, 4> map_matrix_{};
  std::vector<float> map_key_;  // what the maps were drawn from
  long long map_renders_ = 0;
  long long left_out_ = 0;
  long long coarse_draws_ = 0;
  long long culled_draws_ = 0;
  long long samplers_bound_ = 0;
};

}  // namespace mlspaces::sim
