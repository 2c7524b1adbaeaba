#include "mlspaces/sim/scene.h"

#include "mlspaces/core/error.h"
#include "mlspaces/library/scene_metadata.h"

namespace mlspaces::sim {

Scene Scene::Load(const std::filesystem::path& xml, ComposeOptions options) {
  MjcfComposer composer(xml, options);
  std::optional<Json> meta = LoadSceneMetadata(xml);
  Json m = meta ? std::move(*meta) : Json{{"objects", Json::object()}};
  return Scene(std::move(composer), std::move(m), options);
}

std::string Scene::InsertAsset(const Registry& registry, std::string_view uid, const Pose& pose,
                               std::string_view parent_body, std::string_view prefix) {
  AssetLocation loc = registry.LocateOrThrow(uid);
  std::shared_ptr<const Annotation> annotation = registry.GetAnnotation(uid);
  if (!annotation) {
    throw Error("no metadata for " + std::string(uid) + " in library " + loc.library, "", "",
                std::string(uid));
  }
  Json entry = MakeInsertedObjectEntry(*annotation, loc.mjcf_path);
  std::string p = prefix.empty() ? std::string(uid) + "_" + std::to_string(inserted_) + "/"
                                 : std::string(prefix);
  // Parsed and checked first, so that a bad asset leaves the scene as it was.
  const MjcfComposer asset(loc.mjcf_path, options_);
  if (const size_t n = asset.TopLevelBodies().size(); n != 1) {
    throw Error(
        "an inserted asset must have exactly one top-level body, found " + std::to_string(n),
        loc.mjcf_path.string(), "", std::string(uid));
  }
  std::vector<std::string> bodies = composer_.Attach(asset, parent_body, p, pose);
  ++inserted_;
  AddSceneObject(metadata_, bodies[0], std::move(entry));
  return bodies[0];
}

std::vector<std::string> Scene::InsertRobot(const std::filesystem::path& robot_xml,
                                            std::string_view prefix, const Pose& base) {
  return composer_.Attach(robot_xml, "world", prefix, base);
}

std::vector<std::string> Scene::InsertRobotString(std::string_view xml,
                                                  const std::filesystem::path& path_for_errors,
                                                  std::string_view prefix, const Pose& base) {
  return composer_.AttachString(xml, path_for_errors, "world", prefix, base);
}

}  // namespace mlspaces::sim
