// Grasp generation, geometry: an asset's collision geometry as one triangle mesh, area-weighted
// surface sampling, and a BVH for ray casts and box-overlap queries (docs/graspgen.md).
//
// The collision geometry of an object is every geom of its body subtree that takes part in
// contacts (contype or conaffinity non-zero): what MuJoCo collides is what the gripper touches.
// Meshes come from the compiled model's mesh arrays (MuJoCo has already applied scale,
// refpos/refquat and the inertial re-centring); box, sphere, capsule, cylinder and ellipsoid
// are tessellated with outward-facing (counter-clockwise) triangles. Everything is in the
// object body's frame at the model's qpos0.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/transform.h"

namespace mlspaces::graspgen {

/// A triangle soup: vertices (m) and faces (vertex indices, counter-clockwise seen from outside).
struct MLSPACES_API TriMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<int32_t, 3>> faces;
  /// Total area (m^2).
  double Area() const;
};

/// Unit outward normal of face f (zero vector for a degenerate face).
MLSPACES_API Vec3 FaceNormal(const TriMesh& mesh, size_t f);

/// Checks a mesh for grasp generation and drops degenerate faces (area < 1e-12 m^2, e.g.
/// repeated vertices). @throws Error (path = `source`) for no faces, a non-finite vertex, a face
/// index out of range, or no face with area left.
MLSPACES_API TriMesh ValidatedMesh(TriMesh mesh, const std::string& source);

/// The collision geoms of body `body` and its descendants as one mesh in that body's frame.
/// `source` names the asset file in errors. @throws Error for no collision geometry, an
/// unsupported geom type (plane, height field, SDF) or a mesh ValidatedMesh rejects.
MLSPACES_API TriMesh CollisionMesh(const mjModel* model, int body, const std::string& source);

/// The geoms `geoms` (ids, in that order) as one mesh in body `frame`'s frame at qpos0.
/// @throws Error (`source`) for an empty list, an unsupported type or a rejected mesh.
MLSPACES_API TriMesh GeomsMesh(const mjModel* model, const std::vector<int>& geoms, int frame,
                               const std::string& source);

/// Composes and compiles an asset MJCF (sim::ComposeAndCompile) and returns CollisionMesh of
/// its first top-level body (`body` empty) or of the body named `body`. @throws Error.
MLSPACES_API TriMesh AssetCollisionMesh(const std::filesystem::path& asset_file,
                                        const std::string& body = {});

/// Surface samples: point, outward face normal and face index, in sampling order.
struct MLSPACES_API SurfaceSamples {
  std::vector<Vec3> points;
  std::vector<Vec3> normals;
  std::vector<int32_t> faces;
};

/// ceil(area / density) points drawn with probability proportional to face area, uniform on
/// the chosen triangle; deterministic for a seed (core/rng.h). density > 0 (m^2 per point).
MLSPACES_API SurfaceSamples SampleSurface(const TriMesh& mesh, double density, uint64_t seed);

/// An oriented box: centre, row-major rotation (columns = box axes) and half sizes.
struct MLSPACES_API OrientedBox {
  Vec3 center{0, 0, 0};
  Rot3 rot{1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3 half{0, 0, 0};
};

/// The nearest ray hit: distance along the (unit) direction, face index, hit point.
struct MLSPACES_API RayHit {
  double t = 0;
  int32_t face = -1;
  Vec3 point{0, 0, 0};
};

/// Bounding-volume hierarchy over a mesh's triangles (median split, leaves of <= 4 triangles).
/// Holds a copy of the mesh; queries are const and thread-safe.
class MLSPACES_API MeshBvh {
 public:
  explicit MeshBvh(TriMesh mesh);
  const TriMesh& mesh() const { return mesh_; }
  /// Nearest triangle (either side) hit by origin + t*dir with t in [0, tmax]; dir unit length.
  std::optional<RayHit> Raycast(const Vec3& origin, const Vec3& dir, double tmax) const;
  /// True when the box and some triangle intersect (separating-axis test; a box entirely
  /// inside a closed mesh touches no triangle and is not reported, as FCL's mesh distance).
  bool Overlaps(const OrientedBox& box) const;
  /// Number of BVH nodes (for tests).
  size_t NodeCount() const { return nodes_.size(); }

 private:
  struct Node {
    Vec3 lo, hi;
    int32_t first, count;  // leaf: triangle range in order_; inner: count = 0, first = right
  };
  int32_t Build(int32_t begin, int32_t end);
  TriMesh mesh_;
  std::vector<int32_t> order_;
  std::vector<Vec3> centroids_;
  std::vector<Node> nodes_;
};

/// Brute-force nearest hit over all triangles (the reference the BVH is tested against).
MLSPACES_API std::optional<RayHit> RaycastBruteForce(const TriMesh& mesh, const Vec3& origin,
                                                     const Vec3& dir, double tmax);

}  // namespace mlspaces::graspgen
