// Physical facts of a single-body asset computed from its compiled model: mass and boxes.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <filesystem>

#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {

/// What --compute-metadata writes for one asset.
struct MLSPACES_API AssetFacts {
  /// Compiled mass of the asset's one body (kg); mesh inertia as MuJoCo computes it (each
  /// mesh's `inertia` attribute, MuJoCo 3.5's default "legacy" when absent).
  double mass = 0;
  /// Tight box of every geom of the body and its descendants at qpos0, in world axes,
  /// relative to the body's world position (m). Meshes by their vertices; primitives by
  /// their exact extents (a rotated cylinder or ellipsoid is not boxed by its local box).
  std::array<double, 3> aabb_min{0, 0, 0};
  std::array<double, 3> aabb_max{0, 0, 0};
  /// The size of the box centred on the body origin holding every geom, per axis
  /// 2 * max(|aabb_min|, |aabb_max|) (the computed metadata's "boundingBox", docs/sim.md).
  /// Zero without geoms.
  std::array<double, 3> bounding_box{0, 0, 0};
};

/// World-frame box of the geoms of `body` (its own geoms only, not its children's) for the
/// poses in `d`; false when the body has no geoms.
MLSPACES_API bool BodyGeomBox(const mjModel* m, const mjData* d, int body,
                              std::array<double, 3>* lo, std::array<double, 3>* hi);

/// Facts of body 1 of a compiled model (and its descendants' geoms for the boxes).
/// @throws Error when the model has not exactly one body besides the world.
MLSPACES_API AssetFacts ComputeAssetFacts(const mjModel* m,
                                          const std::filesystem::path& path_for_errors);

/// Composes (physics_only: textures, materials and lights skipped; results bitwise equal a
/// full compile's) and compiles an asset MJCF, then computes its facts.
/// @throws Error naming the file, line and element for bad MJCF, or more than one body.
MLSPACES_API AssetFacts ComputeAssetFacts(const std::filesystem::path& xml,
                                          bool physics_only = true);

}  // namespace mlspaces::sim
