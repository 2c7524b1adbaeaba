// Preflight: the input checks a datagen run makes on a scene before its first attempt, so that
// a broken input (an asset_id no library knows, a grasp file with a NaN) stops the run with one
// line naming the file and the field instead of ending in "no_grasp 100%". The same loaders
// serve every attempt (EpisodeRunner), so a failure there names the same file and field.
// docs/datagen.md, "Broken input".
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/library/registry.h"

namespace mlspaces::datagen {

/// The scene metadata file of a scene XML (FindSceneMetadataFile), else the XML itself: the
/// file errors about a scene's objects name.
MLSPACES_API std::filesystem::path SceneMetadataFileFor(const std::filesystem::path& scene_xml);

/// The asset UID of pickup object `body`: objects.<body>.asset_id of `metadata`.
/// @throws Error naming `metadata_file` and the field "objects.<body>.asset_id" when the entry
/// or its asset_id is missing or not a string.
MLSPACES_API std::string PickupAssetId(const Json& metadata,
                                       const std::filesystem::path& metadata_file,
                                       std::string_view body);

/// Every grasp of asset `uid` (pickup object `body`) from the grasp libraries `filter` (empty:
/// all). @throws Error naming `metadata_file` and "objects.<body>.asset_id" when no library
/// knows the UID or none has grasps for it, and the grasp file and "transforms" (with the row)
/// for a bad file (wrong shape, a non-finite value).
MLSPACES_API GraspSet LoadPickupGrasps(const Registry& registry, const std::string& uid,
                                       std::string_view body,
                                       const std::filesystem::path& metadata_file,
                                       const std::vector<std::string>& filter);

/// What PreflightScene found: the pickup candidates it checked, and one error per candidate
/// whose input is broken (in candidate order).
struct MLSPACES_API PreflightReport {
  std::vector<std::string> candidates;
  std::vector<Error> problems;
};

/// Checks the pickup candidates of a scene (task_config.pickup_obj_name when set and a body of
/// the scene, else TaskSampler::CandidateObjects) as every attempt would load them: asset_id, then
/// grasps. Simulates nothing. @throws Error (the first problem's file and field) when every
/// candidate is broken, so that every attempt would fail for an input reason; a scene with at least
/// one good candidate (or none at all: the sampler decides) returns the problems to report.
MLSPACES_API PreflightReport PreflightScene(const Env& env, const std::filesystem::path& scene_xml,
                                            const Registry& registry,
                                            const ExperimentConfig& config);

}  // namespace mlspaces::datagen
