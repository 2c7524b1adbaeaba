#pragma once
// MuJoCo 3.5's builtin shapes (the display lists of mjr_makeContext, render_context.c) as
// triangle arrays, vertex for vertex: the same float arithmetic, so that a shape drawn from
// them covers the pixels MuJoCo's own list covers. Quads become two triangles each.
#include <array>
#include <vector>

namespace mlspaces::sim {

/// The shapes, in the order of MuJoCo's builtin lists (mjrSPHERE ... mjrBOX; the haze is
/// left empty).
enum BuiltinShape {
  kShapeSphere = 0,
  kShapeSphereTop,
  kShapeSphereBottom,
  kShapeCylinder,
  kShapeCylinderOpen,
  kShapeHaze,
  kShapeBox,
  kShapeCount
};

struct BuiltinShapes {
  struct Range {
    int first = 0;  ///< first vertex
    int count = 0;  ///< vertices (3 per triangle)
  };
  /// Interleaved vertices: x y z nx ny nz.
  std::vector<float> vertices;
  std::array<Range, kShapeCount> ranges{};
};

/// The shapes for a model's vis.quality (numslices, numstacks, numquads). `cylinder_stacks`
/// (numstacks when <= 0) divides the cylinders' sides only, which are straight: coarser
/// shapes for shadow maps.
BuiltinShapes MakeBuiltinShapes(int numslices, int numstacks, int numquads,
                                int cylinder_stacks = 0);

}  // namespace mlspaces::sim
