#pragma once
// ShadowPass's pieces (shadow_pass.h): the GL functions it loads, its shaders, and MuJoCo's
// rendering arithmetic it repeats (render_gl3.c and render_util.c of MuJoCo 3.5.0, not
// exported). Private to src/sim.
#define GL_GLEXT_PROTOTYPES 1  // declarations only: the functions are loaded at run time
#include <GL/gl.h>
#include <GL/glext.h>
#include <mujoco/mujoco.h>

#include <array>
#include <vector>

#include "builtin_shapes.h"
#include "shadow_pass.h"

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
  X(DrawElements)                  \
  X(EnableClientState)             \
  X(GenBuffers)                    \
  X(NormalPointer)                 \
  X(VertexPointer)                 \
  X(BindTexture)                   \
  X(BlendFunc)                     \
  X(CallList)                      \
  X(Color4f)                       \
  X(TexGenfv)                      \
  X(TexGeni)                       \
  X(ClearColor)                    \
  X(ClearDepth)                    \
  X(ClearStencil)                  \
  X(ClipPlane)                     \
  X(CullFace)                      \
  X(FrontFace)                     \
  X(Scissor)                       \
  X(StencilFunc)                   \
  X(StencilOp)                     \
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
  X(GetString)                     \
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
  X(Uniform2f)                     \
  X(Uniform3fv)                    \
  X(Uniform4fv)                    \
  X(UniformMatrix4fv)              \
  X(UseProgram)                    \
  X(Viewport)

struct ShadowPass::Gl {
// `name` is a member name, which parentheses would break.
#define MLSPACES_DECLARE(name) \
  decltype(&::gl##name) name = nullptr;  // NOLINT(bugprone-macro-parentheses)
  /// glClipControl (ARB_clip_control), null without it: MuJoCo reverses depth with it.
  decltype(&::glClipControl) ClipControl = nullptr;
  /// Sampler objects (GL 3.3, ARB_sampler_objects), null without them.
  decltype(&::glGenSamplers) GenSamplers = nullptr;
  decltype(&::glDeleteSamplers) DeleteSamplers = nullptr;
  decltype(&::glSamplerParameteri) SamplerParameteri = nullptr;
  decltype(&::glBindSampler) BindSampler = nullptr;
  MLSPACES_SHADOW_PASS_GL(MLSPACES_DECLARE)
#undef MLSPACES_DECLARE
};

namespace detail {

inline constexpr int kMaxShadowLights = 4;
inline constexpr int kMapSlices = 16, kMapStacks = 8;
inline constexpr int kMaxLights = 8;  // the fixed-function lights mjr_render can use

// Texture units: material textures on 0 (2D) and 1 (cube), the shadow maps from 2.
inline constexpr int kUnit2d = 0, kUnitCube = 1, kUnitMap0 = 2;

/// The vertex and fragment shaders' bodies (after "#version 120", the NLIGHT, NMAP and TEXMODE
/// defines and kVaryings, which both declare): MuJoCo's fixed-function lighting per light,
/// shadow lights kept apart. A program per texture mode: on llvmpipe a branch on a uniform
/// costs every fragment the texture lookups it skips.
extern const char* const kVaryings;
extern const char* const kVertexShader;
extern const char* const kFragmentShader;

/// Directional and spot lights: what MuJoCo's fixed-function renderer lights with.
bool Supported(const mjvLight& l);
/// MuJoCo's isBehind: the eye on the back side of the geom's xy-plane.
bool Behind(const float* head, const mjvGeom& g);
/// The scene camera's position (mjv_cameraInModel), in float.
void HeadPos(const mjvScene& scn, float head[3]);
/// mjr_render's projection before its frustum: identity, then depth reversed (into [0, 1]
/// with ARB_clip_control, `zero_to_one`, else [-1, 1]). Leaves GL_PROJECTION current.
void LoadReversedDepth(const ShadowPass::Gl& gl, bool zero_to_one);
/// Column-major 4x4 product a*b.
std::array<float, 16> Mul(const float* a, const float* b);
/// Inverse of a rigid column-major transform.
std::array<float, 16> InverseRigid(const float* m);
/// mjr_orthoVec: a unit vector orthogonal to v.
void OrthoVec(float* res, const float* v);
/// mjr_lookAt's matrix (column-major).
std::array<float, 16> LookAtMatrix(const float* eye, const float* forward, const float* up);
/// A bounding radius of a builtin shape about its position; -1 for other types.
float BoundingRadius(const mjvGeom& g);
/// A radius about its position that holds every vertex DrawGeom draws for `g`: builtin
/// shapes from their size, meshes from `mesh_radius` (per mesh id); -1 when unknown (planes,
/// height fields, other types).
float DrawnRadius(const mjvGeom& g, const std::vector<float>& mesh_radius);
/// The six planes (a, b, c, d: inside where a x + b y + c z + d >= 0, unit normals) of the
/// view volume of a column-major clip matrix (projection * modelview), in the modelview's
/// input coordinates.
using ViewVolume = std::array<std::array<float, 4>, 6>;
ViewVolume ViewVolumeOf(const float* clip);
/// Whether the sphere lies wholly outside one of the planes, with a margin: what it holds
/// is then clipped away entirely, and leaving it out changes no pixel. False for radius < 0.
bool Outside(const ViewVolume& f, const float* center, float radius);
/// Whether the sphere lies wholly between the near and far planes of `f` (planes 4 and 5),
/// with Outside's margin: no part of it is clipped by either. False for radius < 0.
bool WithinDepth(const ViewVolume& f, const float* center, float radius);
/// mjv_rbound (MuJoCo 3.5's engine_vis_init.c, not exported): the model geom's radius, else
/// one from the size; mjr_render sorts transparent geoms by it. Unlike BoundingRadius, not a
/// bound for every type (arrows).
float Rbound(const mjvGeom& g);
/// The geom types DrawGeom draws.
bool DrawnType(int type);
/// Builtin shapes with straight sides (cylinders, capsule sides, boxes) cut into fewer pieces
/// than MuJoCo's, all in one GL buffer (x y z nx ny nz per vertex). Each covers the pixels
/// MuJoCo's shape covers, with the same normals; only the per-vertex lighting along a side is
/// sampled at fewer points, which matters where the side spans a wide angle seen from the eye
/// or a positional light (CoarseLevelFor).
struct CoarseLevel {
  int pieces = 0;  ///< cylinder side stacks and box quads per side; disks get pieces / 2 rings
  unsigned int buffer = 0;
  /// Per builtin shape (BuiltinShape); a count of 0 keeps MuJoCo's display list.
  std::array<BuiltinShapes::Range, kShapeCount> ranges{};
};
struct CoarseSides {
  unsigned int buffer = 0;
  std::vector<CoarseLevel> levels;  ///< pieces 1, 2, 4, ... below MuJoCo's numstacks
  int numquads = 0;                 ///< MuJoCo's box quads per side
  int numstacks = 0;                ///< MuJoCo's cylinder side stacks
};
/// The levels for `m`'s vis.quality, uploaded into a new buffer (the caller deletes it).
CoarseSides MakeCoarseSides(const ShadowPass::Gl& gl, const mjModel* m);
/// The coarsest level whose pieces each span at most kCoarsePieceAngle radians seen from `eye`
/// and from each of the `npoint` positions in `points` (positional lights), or null when
/// MuJoCo's own shape is needed (other types, or no coarser level is fine enough).
inline constexpr float kCoarsePieceAngle = 0.25f;
const CoarseLevel* CoarseLevelFor(const CoarseSides& coarse, const mjvGeom& g, const float* eye,
                                  const float* points, int npoint);
/// renderGeom's transform and MuJoCo's display lists (a cylinder, capsule side or box from
/// `coarse` when not null). A plane is drawn as seen from the front.
void DrawGeom(const ShadowPass::Gl& gl, const mjvGeom& g, const mjrContext& con,
              const CoarseLevel* coarse = nullptr);
/// Whether mesh `mesh` of `m` is closed with its faces turned outward: each directed edge of
/// a face (by vertex index) is in no other face, its reverse in exactly one, and the volume
/// is positive. From outside, its back faces are then always behind its front faces.
bool MeshClosed(const mjModel* m, int mesh);
/// Builtin shapes as positions only, each distinct position once, and triangles indexing
/// them: a depth map needs no normals, and llvmpipe then transforms a shared vertex once.
struct IndexedShapes {
  struct Range {
    int first_vertex = 0, vertex_count = 0;  ///< into positions, 3 floats per vertex
    int first_index = 0, index_count = 0;    ///< into indices, local to the shape's vertices
  };
  std::vector<float> positions;
  std::vector<unsigned int> indices;
  std::array<Range, kShapeCount> ranges{};
};
/// `shapes` with their vertices merged by position: the same triangles, in the same order.
IndexedShapes IndexShapes(const BuiltinShapes& shapes);
/// Appends the triangles of `g`'s builtin shape (sphere, ellipsoid, capsule, cylinder, box) in
/// world coordinates, as renderGeom places them: its vertices to `positions` (x y z each) and
/// its triangles to `indices` (into the whole of `positions`). False, with nothing appended,
/// for other types.
bool AppendWorldShape(const IndexedShapes& shapes, const mjvGeom& g, std::vector<float>* positions,
                      std::vector<unsigned int>* indices);

/// settexture's choice for a geom: mode (the shader's TEXMODE: 0 none, 1 texture
/// coordinates, 2 2D object planes, 3 cube), GL texture and object planes.
struct GeomTexture {
  int mode = 0;
  unsigned int texture = 0;
  float s[4] = {0, 0, 0, 0}, t[4] = {0, 0, 0, 0}, r[4] = {0, 0, 0, 0};
};
GeomTexture TextureOf(const mjvGeom& g, const mjrContext& con);

}  // namespace detail
}  // namespace mlspaces::sim
