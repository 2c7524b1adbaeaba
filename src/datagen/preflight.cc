// Preflight: pickup candidates checked as every attempt loads them (preflight.h).
#include "mlspaces/datagen/preflight.h"

#include <limits>

#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/library/scene_metadata.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
namespace {

std::string AssetIdField(std::string_view body) {
  return "objects." + std::string(body) + ".asset_id";
}

std::string NamesOrNone(const std::vector<std::string>& names) {
  return names.empty() ? "none" : JoinNames(names);
}

}  // namespace

fs::path SceneMetadataFileFor(const fs::path& scene_xml) {
  if (scene_xml.extension() == ".xml") {
    if (std::optional<fs::path> file = FindSceneMetadataFile(scene_xml)) return *file;
  }
  return scene_xml;
}

std::string PickupAssetId(const Json& metadata, const fs::path& metadata_file,
                          std::string_view body) {
  const std::string field = AssetIdField(body);
  const std::string object = "pickup object " + std::string(body);
  const auto objects = metadata.is_object() ? metadata.find("objects") : metadata.end();
  if (objects == metadata.end() || !objects->is_object()) {
    throw Error(object + ": the scene metadata has no objects", metadata_file.string(), field);
  }
  const auto entry = objects->find(std::string(body));
  if (entry == objects->end() || !entry->is_object()) {
    throw Error(object + " is not in the scene metadata", metadata_file.string(), field);
  }
  const auto id = entry->find("asset_id");
  if (id == entry->end() || !id->is_string() || id->get<std::string>().empty()) {
    throw Error(object + ": missing asset_id (a non-empty string)", metadata_file.string(), field);
  }
  return id->get<std::string>();
}

GraspSet LoadPickupGrasps(const Registry& registry, const std::string& uid, std::string_view body,
                          const fs::path& metadata_file, const std::vector<std::string>& filter) {
  const std::string field = AssetIdField(body);
  if (!registry.Locate(uid) && !registry.GetAnnotation(uid)) {
    throw Error(
        "asset_id '" + uid + "' of pickup object " + std::string(body) +
            " is in no asset library (registered: " + NamesOrNone(registry.asset_libraries()) + ")",
        metadata_file.string(), field, uid);
  }
  try {
    return registry.LoadGrasps({uid, "", filter}, std::numeric_limits<size_t>::max());
  } catch (const Error& e) {
    if (!e.path().empty()) throw;  // the grasp file and its field (transforms, row)
    const std::vector<std::string> libraries = registry.GraspLibrariesFor(uid, filter);
    throw Error(
        e.message() + " (pickup object " + std::string(body) +
            "; grasp libraries asked: " + NamesOrNone(libraries) +
            (filter.empty() ? std::string()
                            : ", of policy_config.grasp_libraries [" + NamesOrNone(filter) + "]") +
            ")",
        metadata_file.string(), field, uid);
  }
}

PreflightReport PreflightScene(const Env& env, const fs::path& scene_xml, const Registry& registry,
                               const ExperimentConfig& config) {
  PreflightReport report;
  if (const std::optional<std::string>& name = config.task_config.pickup_obj_name) {
    // A name that is no body of the scene: the sampler's own error says so.
    if (mj_name2id(env.model(), mjOBJ_BODY, name->c_str()) >= 0) report.candidates = {*name};
  } else {
    report.candidates = TaskSampler::CandidateObjects(env);
  }
  const fs::path metadata_file = SceneMetadataFileFor(scene_xml);
  const std::vector<std::string> filter = config.policy_config.grasp_libraries
                                              ? *config.policy_config.grasp_libraries
                                              : std::vector<std::string>{};
  for (const std::string& body : report.candidates) {
    try {
      const std::string uid = PickupAssetId(env.metadata(), metadata_file, body);
      LoadPickupGrasps(registry, uid, body, metadata_file, filter);
    } catch (const Error& e) {
      report.problems.push_back(e);
    }
  }
  if (!report.candidates.empty() && report.problems.size() == report.candidates.size()) {
    const Error& first = report.problems.front();
    const size_t others = report.problems.size() - 1;
    throw Error(first.message() + (others == 0 ? std::string(" (the scene's only pickup candidate)")
                                               : " (and the " + std::to_string(others) +
                                                     " other pickup candidates are broken too)"),
                first.path(), first.field(), first.uid());
  }
  return report;
}

}  // namespace mlspaces::datagen
