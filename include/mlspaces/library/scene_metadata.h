// Scene metadata: <scene>_metadata.json beside a scene XML, and its update when objects are
// inserted at run time.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "mlspaces/core/json.h"
#include "mlspaces/library/annotation.h"

namespace mlspaces {

/// The metadata file for a scene XML: `X_ceiling.xml` ->
/// `X_metadata.json`, else `X.xml` -> `X_metadata.json`; if that file does not exist, try the
/// stem cut at each '_' from the right (`a_b_c` -> `a_b_metadata.json`, `a_metadata.json`).
/// Only the file name is looked at ("ceiling" or ".xml" in a folder name changes nothing).
/// nullopt if none exists. @throws Error if the path is not "*.xml".
MLSPACES_API std::optional<std::filesystem::path> FindSceneMetadataFile(
    const std::filesystem::path& xml);

/// Loads the scene metadata for a scene XML; nullopt when there is none.
/// @throws Error for a bad file (not JSON, not an object, "objects" not an object).
MLSPACES_API std::optional<Json> LoadSceneMetadata(const std::filesystem::path& xml);

/// The entry for an object inserted at run time: {"asset_id", "category", "object_enum":
/// "temp_object", "is_static": false, "boundingBox", "asset_library", "mjcf_path"}.
MLSPACES_API Json MakeInsertedObjectEntry(const Annotation& annotation,
                                          const std::filesystem::path& mjcf);

/// Adds `entry` under objects[body_name]; first write wins (returns false if present).
/// Creates {"objects": {}} when the scene had no metadata.
MLSPACES_API bool AddSceneObject(Json& scene_metadata, const std::string& body_name, Json entry);

/// The UID of a scene body: objects[body_name].asset_id. @throws Error "Could not load grasps
/// for object <name>: No scene metadata found!" / "...: Object not found in scene metadata!"
/// / missing or non-string asset_id.
MLSPACES_API std::string SceneObjectAssetId(const std::optional<Json>& scene_metadata,
                                            std::string_view body_name);

}  // namespace mlspaces
