// Run-time scene composition: a scene file + its metadata, objects inserted by UID, a robot
// inserted under a prefix, compiled to one mjModel.
//
// Lifetimes: metadata() and composer() are valid while the Scene lives and change with each
// insertion; a compiled model is owned by the caller and outlives the Scene.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/json.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/sim/mjcf_composer.h"

namespace mlspaces::sim {

class MLSPACES_API Scene {
 public:
  // ===========================================================================================
  // Construction

  /// Composes `xml` (MuJoCo's parser: <include>, <frame>, <model>, <attach>, ...) and loads
  /// its scene metadata
  /// (<scene>_metadata.json rules of FindSceneMetadataFile); {"objects": {}} when it has none.
  /// @throws Error for bad MJCF or bad metadata.
  static Scene Load(const std::filesystem::path& xml, ComposeOptions options = {});

  // ===========================================================================================
  // Insertion

  /// Inserts the asset `uid` (located through `registry`, user libraries included) under body
  /// `parent_body` ("world" for the worldbody) at `pose`, with `prefix` on every name (empty:
  /// "<uid>_<n>/", n counting insertions). Adds a scene-metadata entry keyed by the inserted
  /// body's name: asset_id, category, object_enum "temp_object", is_static false, boundingBox,
  /// asset_library and mjcf_path (the scene-metadata format: docs/formats.md).
  /// @returns that body name. @throws Error for an unknown UID or one without metadata.
  std::string InsertAsset(const Registry& registry, std::string_view uid, const Pose& pose,
                          std::string_view parent_body = "world", std::string_view prefix = {});

  /// Inserts a robot MJCF under `prefix` (e.g. "robot_0/") with its base at `base` in the
  /// world. @returns the robot's top-level body names.
  std::vector<std::string> InsertRobot(const std::filesystem::path& robot_xml,
                                       std::string_view prefix, const Pose& base);

  /// InsertRobot for a robot model given as MJCF text; its relative paths resolve against
  /// `path_for_errors`'s folder, and errors name that path.
  std::vector<std::string> InsertRobotString(std::string_view xml,
                                             const std::filesystem::path& path_for_errors,
                                             std::string_view prefix, const Pose& base);

  // ===========================================================================================
  // Compiling and access

  /// Leaves the bodies whose names start with `prefix`, with everything under them, out of
  /// the compiled model's statistic (mjModel::stat center and extent, computed as MuJoCo
  /// computes them from the rest): bodies parked far from the scene (pick-and-place's unused
  /// receptacles, 35 m up) would otherwise set the scale MuJoCo renders at, the cameras'
  /// near plane (vis.map.znear x extent) first. A centre or extent the scene sets
  /// (<statistic>) is kept.
  void ExcludeFromStatistic(std::string prefix);

  /// Compiles the composed scene: never null, owned by the caller. @throws Error with file,
  /// line and element.
  ModelPtr Compile() const;

  /// The scene metadata, {"objects": {...}} with the inserted objects' entries; valid while
  /// the Scene lives.
  const Json& metadata() const { return metadata_; }
  /// The composer holding the scene and everything inserted; valid while the Scene lives.
  const MjcfComposer& composer() const { return composer_; }

 private:
  Scene(MjcfComposer composer, Json metadata, ComposeOptions options)
      : composer_(std::move(composer)), metadata_(std::move(metadata)), options_(options) {}

  MjcfComposer composer_;
  Json metadata_;
  ComposeOptions options_;
  int inserted_ = 0;
  std::vector<std::string> excluded_;  // ExcludeFromStatistic's prefixes
};

}  // namespace mlspaces::sim
