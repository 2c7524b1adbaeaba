// Fast mesh readers for the physics-only compile: OBJ and binary STL read into the triangle
// soup MuJoCo 2.2.2 would build from them, handed back to MuJoCo as a binary .msh file.
//
// MuJoCo 2.2.2's OBJ loader (tinyobjloader, triangulate on) makes one mesh vertex per face
// corner, so a 1,000-vertex OBJ becomes ~6,000 mesh vertices and its mesh processing dominates
// the compile. Mass, inertia, the mesh frame (centre of mass, principal axes) and every vertex
// position depend only on the triangles' float corner positions taken face by face, never on
// how vertices are shared or ordered, so a mesh with one vertex per OBJ index and the same
// triangles in the same order compiles to the same numbers. What the readers keep from
// MuJoCo/tinyobjloader: float vertices parsed with tinyobjloader's digit-by-digit arithmetic,
// 1-based and negative (relative) indices, quads and polygons triangulated by the ear clipping
// of the tinyobjloader built into Debian's MuJoCo 2.2.2 (float arithmetic, whole-polygon
// signed area; neither a fan nor tinyobjloader 2.0's shorter-diagonal quad split matches it,
// and a quad's split changes the volume), only the vertices faces use. What they leave to
// MuJoCo (the reader returns false and the original file is compiled): several shapes
// (o/g/usemtl after the first face), lines and points, faces of fewer than three corners, no
// faces, fewer than four distinct vertices, inconsistently oriented faces (MuJoCo's own error),
// ASCII or otherwise invalid STL (MuJoCo's own error). A malformed OBJ is reported before any
// of that, so MuJoCo's loader never sees bad indices.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace mlspaces::sim {

/// Triangles over shared float vertices.
struct TriMesh {
  std::vector<float> vert;  // 3 per vertex
  std::vector<int> face;    // 3 per triangle, 0-based
};

/// Reads OBJ text as MuJoCo 2.2.2 would. @returns false when MuJoCo should read the file itself.
/// @throws Error(path, "line N") for a malformed line (bad number, bad or out-of-range index).
bool ReadObjMesh(std::string_view text, const std::string& path, TriMesh* out);

/// Reads a binary STL as MuJoCo 2.2.2 would (repeated corners shared); false when MuJoCo should
/// read (and reject or accept) the file itself.
bool ReadStlMesh(std::string_view data, TriMesh* out);

/// MuJoCo's binary .msh: int32 nvertex, nnormal (= nvertex), ntexcoord (0), nface, then float
/// vertices, placeholder float normals (+z: only rendering uses normals, and given ones spare
/// MuJoCo computing them) and int32 faces.
std::string EncodeMsh(const TriMesh& mesh);

}  // namespace mlspaces::sim
