// Scene metadata (spec 10), with the original's naming bugs fixed: only the XML's file name
// is looked at, so "ceiling" or ".xml" in a folder name changes nothing.
#include "mlspaces/library/scene_metadata.h"

#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

constexpr std::string_view kXml = ".xml";
constexpr std::string_view kCeilingXml = "_ceiling.xml";
constexpr std::string_view kMetadataSuffix = "_metadata.json";

}  // namespace

std::optional<fs::path> FindSceneMetadataFile(const fs::path& xml) {
  const std::string name = xml.filename().string();
  if (!name.ends_with(kXml)) {
    throw Error("Scene is supposed to be xml (" + xml.string() + " given)", xml.string());
  }
  const fs::path dir = xml.parent_path();
  const std::string stem = name.substr(0, name.size() - kXml.size());
  // Primary candidate: X_ceiling.xml -> X_metadata.json, else X.xml -> X_metadata.json.
  std::string base = stem;
  if (name.ends_with(kCeilingXml)) base = name.substr(0, name.size() - kCeilingXml.size());
  fs::path candidate = dir / (base + std::string(kMetadataSuffix));
  if (IsFile(candidate)) return candidate;
  // Fallback: the stem cut at each '_' from the right (empty parts kept, as str.split).
  std::vector<size_t> cuts;  // lengths of the prefixes to try, longest first
  cuts.push_back(stem.size());
  for (size_t i = stem.size(); i-- > 0;) {
    if (stem[i] == '_') cuts.push_back(i);
  }
  for (size_t len : cuts) {
    candidate = dir / (stem.substr(0, len) + std::string(kMetadataSuffix));
    if (IsFile(candidate)) return candidate;
  }
  return std::nullopt;
}

std::optional<Json> LoadSceneMetadata(const fs::path& xml) {
  std::optional<fs::path> file = FindSceneMetadataFile(xml);
  if (!file) return std::nullopt;
  Json meta = ParseJsonFile(*file);
  if (!meta.is_object()) {
    throw Error("scene metadata must be a JSON object, got " + JsonTypeName(meta), file->string());
  }
  auto objects = meta.find("objects");
  if (objects != meta.end() && !objects->is_object()) {
    throw Error("\"objects\" must be an object, got " + JsonTypeName(*objects), file->string(),
                "/objects");
  }
  return meta;
}

Json MakeInsertedObjectEntry(const Annotation& annotation, const fs::path& mjcf) {
  auto category = annotation.json.find("category");
  if (category == annotation.json.end()) {
    throw Error("metadata has no \"category\" (needed to insert the object into a scene)", "",
                "/category", annotation.uid);
  }
  Json entry = Json::object();
  entry["asset_id"] = annotation.uid;
  entry["category"] = *category;
  entry["object_enum"] = "temp_object";
  entry["is_static"] = false;
  auto bbox = annotation.json.find("boundingBox");
  entry["boundingBox"] = bbox == annotation.json.end() ? Json::object() : *bbox;
  entry["asset_library"] = annotation.library;
  entry["mjcf_path"] = mjcf.string();
  return entry;
}

bool AddSceneObject(Json& scene_metadata, const std::string& body_name, Json entry) {
  if (scene_metadata.is_null()) scene_metadata = Json::object();
  if (!scene_metadata.is_object()) {
    throw Error("scene metadata must be a JSON object, got " + JsonTypeName(scene_metadata));
  }
  Json& objects = scene_metadata["objects"];
  if (objects.is_null()) objects = Json::object();
  if (!objects.is_object()) {
    throw Error("\"objects\" must be an object, got " + JsonTypeName(objects), "", "/objects");
  }
  if (objects.contains(body_name)) return false;
  objects[body_name] = std::move(entry);
  return true;
}

std::string SceneObjectAssetId(const std::optional<Json>& scene_metadata,
                               std::string_view body_name) {
  const std::string prefix = "Could not load grasps for object " + std::string(body_name) + ": ";
  if (!scene_metadata || !scene_metadata->is_object()) {
    throw Error(prefix + "No scene metadata found!");
  }
  auto objects = scene_metadata->find("objects");
  if (objects == scene_metadata->end() || !objects->is_object()) {
    throw Error(prefix + "Object not found in scene metadata!");
  }
  auto entry = objects->find(std::string(body_name));
  if (entry == objects->end()) throw Error(prefix + "Object not found in scene metadata!");
  const std::string field = "/objects/" + JsonPointerToken(body_name) + "/asset_id";
  if (!entry->is_object()) throw Error(prefix + "entry is not an object", "", field);
  auto asset_id = entry->find("asset_id");
  if (asset_id == entry->end()) throw Error(prefix + "missing asset_id", "", field);
  if (!asset_id->is_string()) {
    throw Error(prefix + "asset_id must be a string, got " + JsonTypeName(*asset_id), "", field);
  }
  return asset_id->get<std::string>();
}

}  // namespace mlspaces
