// Licences of MolmoSpaces data (include/mlspaces/resources/license.h, docs/licenses.md).
#include "mlspaces/resources/license.h"
#include "mlspaces/resources/molmo_remote.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/library/scene_metadata.h"
#include "mlspaces/resources/package.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

/// Biggest tries file we inflate (the real ones are tens of MB).
constexpr size_t kMaxTriesBytes = size_t{1} << 30;

// The Ai2 licence every in-house item carries, and its attribution template.
constexpr char kAi2License[] = "CC-BY-4.0";
constexpr char kAi2LicenseUrl[] = "https://creativecommons.org/licenses/by/4.0/";
constexpr char kAi2Creator[] = "Allen Institute for AI (Ai2)";

std::string Quoted(std::string_view s) { return "'" + std::string(s) + "'"; }

Json Ai2Fields() {
  return Json{{"license", kAi2License},
              {"license_url", kAi2LicenseUrl},
              {"creator_name", kAi2Creator},
              {"source", "In-house"}};
}

/// "<what> by the Allen Institute for AI (Ai2), licensed under CC BY 4.0."
std::string Ai2Attribution(std::string_view what) {
  return std::string(what) + " by the " + kAi2Creator + ", licensed under CC BY 4.0.";
}

/// `base` followed by the members of `more`, in order.
Json Merged(Json base, const Json& more) {
  for (const auto& [key, value] : more.items()) base[key] = value;
  return base;
}

const Json* Member(const Json& object, std::string_view key) {
  if (!object.is_object()) return nullptr;
  const auto it = object.find(std::string(key));
  return it == object.end() ? nullptr : &*it;
}

std::string RequiredString(const Json& object, std::string_view key, const std::string& pointer,
                           const std::string& file, const std::string& uid) {
  const Json* value = Member(object, key);
  if (value == nullptr) throw Error("missing", file, pointer + "/" + std::string(key), uid);
  if (!value->is_string()) {
    throw Error("expected a string, got " + JsonTypeName(*value), file,
                pointer + "/" + std::string(key), uid);
  }
  return value->get<std::string>();
}

/// An annotation's isObjaverse. @throws Error when missing or not a boolean.
bool IsObjaverse(const Annotation& annotation) {
  const Json* value = Member(annotation.json, "isObjaverse");
  if (value == nullptr || !value->is_boolean()) {
    throw Error(value == nullptr ? "missing" : "expected a boolean, got " + JsonTypeName(*value),
                annotation.library, "/isObjaverse", annotation.uid);
  }
  return value->get<bool>();
}

std::string ReadGzip(const fs::path& path) {
  std::unique_ptr<gzFile_s, int (*)(gzFile)> file(gzopen(path.c_str(), "rb"), gzclose);
  if (!file) throw Error("cannot open", path.string());
  std::string out;
  char buf[1 << 16];
  for (;;) {
    const int n = gzread(file.get(), buf, sizeof buf);
    if (n < 0) throw Error("not a readable gzip file", path.string());
    if (n == 0) break;
    out.append(buf, static_cast<size_t>(n));
    if (out.size() > kMaxTriesBytes) throw Error("inflates to more than 1 GiB", path.string());
  }
  return out;
}

/// The file paths of a trie ({component or 'a/b' run: subtrie}, a leaf file is {}), in order.
void TrieLeaves(const Json& trie, const std::string& prefix, std::vector<std::string>& out,
                const std::string& file) {
  if (!trie.is_object()) throw Error("a trie node is not an object", file, prefix);
  for (const auto& [key, child] : trie.items()) {
    const std::string path = prefix.empty() ? key : prefix + "/" + key;
    if (child.is_object() && child.empty()) {
      out.push_back(path);
    } else {
      TrieLeaves(child, path, out, file);
    }
  }
}

/// The member paths of `archive` from the source's tries file next to its size manifest, or
/// nullopt when there is no tries file.
std::optional<std::vector<std::string>> ArchiveMembers(const LicenseContext& context,
                                                       std::string_view data_type,
                                                       std::string_view source,
                                                       const std::string& archive) {
  const std::optional<fs::path> manifest = FindSizeManifest(context, data_type, source);
  if (!manifest) return std::nullopt;
  const fs::path tries = manifest->parent_path() / kTriesFile;
  std::error_code ec;
  if (!fs::is_regular_file(tries, ec)) return std::nullopt;
  const Json all = ParseJson(ReadGzip(tries), tries.string());
  const Json* trie = Member(all, archive);
  if (trie == nullptr) throw Error("no trie for archive " + archive, tries.string());
  std::vector<std::string> out;
  TrieLeaves(*trie, "", out, tries.string());
  return out;
}

// ---------------------------------------------------------------------------------------------
// Objects

/// The original's validate_{thor,objaverse}_identifier.
std::string ValidateObjectIdentifier(const LicenseContext& context, std::string_view source,
                                     std::string_view identifier) {
  const bool want_objaverse = source == "objaverse";
  if (auto annotation = context.registry->GetAnnotation(identifier)) {
    if (IsObjaverse(*annotation) != want_objaverse) {
      throw Error("identifier=" + Quoted(identifier) + " is not in `" + std::string(source) + "`",
                  "", "", std::string(identifier));
    }
    return std::string(identifier);
  }
  return ValidateIdentifier(SourceArchiveNames(context, "objects", source), "objects", source,
                            identifier);
}

struct CcLicense {
  const char* key;
  const char* spdx;
  const char* url;
  const char* words;  ///< as the attribution spells it
};
constexpr CcLicense kCcLicenses[] = {
    {"by", "CC-BY-4.0", "https://creativecommons.org/licenses/by/4.0/", "CC BY 4.0"},
    {"by-sa", "CC-BY-SA-4.0", "https://creativecommons.org/licenses/by-sa/4.0/", "CC BY-SA 4.0"},
    {"cc0", "CC0-1.0", "https://creativecommons.org/publicdomain/zero/1.0/", "CC0-1.0"},
    {"by-nc", "CC-BY-NC-4.0", "https://creativecommons.org/licenses/by-nc/4.0/", "CC BY-NC 4.0"},
    {"by-nc-sa", "CC-BY-NC-SA-4.0", "https://creativecommons.org/licenses/by-nc-sa/4.0/",
     "CC BY-NC-SA 4.0"},
};

const CcLicense* FindCcLicense(std::string_view key) {
  for (const CcLicense& l : kCcLicenses) {
    if (key == l.key) return &l;
  }
  return nullptr;
}

/// The licence-specific keys the original adds for a Creative Commons short name.
void AddCcFields(Json& out, const CcLicense& l, const std::string& model_by) {
  const std::string key = l.key;
  out["license"] = l.spdx;
  out["license_url"] = l.url;
  const bool nc = IsNonCommercialLicense(key);
  if (nc) out["commercial_use"] = false;
  if (key == "by-sa")
    out["derivative_license"] = "This derivative work is licensed under CC BY-SA 4.0.";
  if (key == "by-nc-sa") {
    out["derivative_license"] = "This derivative work is licensed under CC BY-NC-SA 4.0.";
  }
  if (key == "by") out["derivative_notice"] = "This work is a derivative of the original model.";
  if (key == "cc0") {
    out["derivative_notice"] =
        "This work is a derivative of the original asset, which was released under CC0.";
  }
  if (nc) {
    out["derivative_notice"] =
        "This work is a derivative of the original asset and may not be used for commercial "
        "purposes.";
  }
  out["attribution"] = model_by + ", licensed under " + l.words + "." +
                       (nc ? std::string(" Non-commercial use only.") : std::string());
}

Json ResolveObjaverse(const LicenseContext& context, std::string_view identifier) {
  const std::string uid = ValidateObjectIdentifier(context, "objaverse", identifier);
  const auto annotation = context.registry->GetAnnotation(uid);
  if (!annotation) {
    throw Error("no annotation for " + uid + " (the objathor_metadata store is not installed?)", "",
                "", uid);
  }
  const std::string file = annotation->library;
  const Json* info = Member(annotation->json, "license_info");
  if (info == nullptr || !info->is_object()) {
    throw Error(info == nullptr ? "missing" : "expected an object", file, "/license_info", uid);
  }
  const std::string url = RequiredString(*info, "creator_profile_url", "/license_info", file, uid);
  if (url.find("sketchfab") == std::string::npos) {
    throw Error("Only sketchfab assets expected, got " + url, file,
                "/license_info/creator_profile_url", uid);
  }
  const std::string user = RequiredString(*info, "creator_username", "/license_info", file, uid);
  const std::string name =
      RequiredString(*info, "creator_display_name", "/license_info", file, uid);
  const std::string key = RequiredString(*info, "license", "/license_info", file, uid);
  const CcLicense* cc = FindCcLicense(key);
  if (cc == nullptr) {
    throw Error("Got unsupported license " + key, file, "/license_info/license", uid);
  }
  Json out{{"data_type", "objects"},
           {"data_source", "objaverse"},
           {"asset_id", RequiredString(annotation->json, "assetId", "", file, uid)},
           {"creator_username", user},
           {"creator_display_name", name},
           {"creator_profile_url", url},
           {"source", "Sketchfab"},
           {"uri", RequiredString(*info, "uri", "/license_info", file, uid)},
           {"downloaded", "2021-2022"},
           {"license_determination",
            "License inferred from Sketchfab designation at time of download (circa 2021/2022)."},
           {"modifications",
            "The model has been significantly modified to reduce memory and processing "
            "requirements, including mesh decimation, convex collider extraction, and baking of "
            "visual effects via Blender scripts. The provided quality may not reflect the "
            "original model."},
           {"dataset_license", "This subset of Objaverse is licensed under ODC-BY 1.0."}};
  AddCcFields(out, *cc, "Model by " + name + " (" + user + ")");
  return out;
}

/// A user library's asset: its metadata's license_info when there is one, else "unknown".
Json ResolveUserObject(const LicenseContext& context, std::string_view library,
                       std::string_view uid) {
  const Registry& registry = *context.registry;
  const std::optional<AssetLocation> where = registry.Locate(uid);
  const auto annotation = registry.GetAnnotation(uid);
  const bool in_library =
      (annotation && annotation->library == library) || (where && where->library == library);
  if (!in_library) {
    throw Error("identifier=" + Quoted(uid) + " is not in user library `" + std::string(library) +
                    "`" + (where ? " (it is in `" + where->library + "`)" : std::string()),
                "", "", std::string(uid));
  }
  Json out{{"data_type", "objects"}, {"data_source", library}, {"asset_id", uid}};
  const Json* info = annotation && annotation->library == library
                         ? Member(annotation->json, "license_info")
                         : nullptr;
  if (info == nullptr || !info->is_object()) {
    out["license"] = "unknown";
    out["license_determination"] =
        "The asset's metadata in user library `" + std::string(library) +
        "` has no license_info object; ask the library's author for its licence.";
    return out;
  }
  const std::string file = annotation->library;
  auto optional_string = [&](const char* key) -> std::string {
    const Json* v = Member(*info, key);
    return v != nullptr && v->is_string() ? v->get<std::string>() : std::string();
  };
  const std::string user = optional_string("creator_username");
  const std::string name = optional_string("creator_display_name");
  for (const char* key : {"creator_username", "creator_display_name", "creator_profile_url"}) {
    if (const std::string v = optional_string(key); !v.empty()) out[key] = v;
  }
  if (const std::string v = optional_string("source"); !v.empty()) out["source"] = v;
  if (const std::string v = optional_string("uri"); !v.empty()) out["uri"] = v;
  out["license_determination"] = "From the license_info of the asset's metadata in user library `" +
                                 std::string(library) + "`.";
  const std::string key = RequiredString(*info, "license", "/license_info", file, std::string(uid));
  std::string lower;
  for (char c : key) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::string model_by = "Model";
  if (!name.empty()) model_by += " by " + name + (user.empty() ? "" : " (" + user + ")");
  if (const CcLicense* cc = FindCcLicense(lower)) {
    AddCcFields(out, *cc, model_by);
  } else {
    // Not one of the Creative Commons short names: reported as written.
    out["license"] = key;
    out["attribution"] = model_by + ", licensed under " + key + ".";
  }
  return out;
}

Json ResolveObject(const LicenseContext& context, std::string_view source,
                   std::string_view identifier) {
  if (source == "objaverse") return ResolveObjaverse(context, identifier);
  if (source == "thor") {
    Json out{{"data_type", "objects"},
             {"data_source", "thor"},
             {"asset_id_or_archive_name", ValidateObjectIdentifier(context, source, identifier)}};
    out = Merged(std::move(out), Ai2Fields());
    out["attribution"] = Ai2Attribution("Model(s)");
    return out;
  }
  if (source == "objathor_metadata") {
    Json out{
        {"data_type", "objects"}, {"data_source", "objathor_metadata"}, {"asset_id", identifier}};
    out = Merged(std::move(out), Ai2Fields());
    out["attribution"] = Ai2Attribution(
        "Object annotation (bounding boxes, masses, synsets, CLIP features, etc.) extracted");
    out["scope"] =
        "Annotation data derived from objects, including bounding boxes, physical properties, "
        "descriptions, CLIP embedding\u2013based representations, and semantic labels.";
    out["relationship_to_objects"] = "annotation";
    out["object_licenses"] =
        "Underlying objects are independently licensed; see each object's license for details "
        "(under `objects` - `thor` and `objects` - `objaverse`).";
    out["license_note"] =
        "This license applies only to the annotation data. Underlying objects are independently "
        "licensed and are not covered by this license.";
    return out;
  }
  const std::vector<std::string> libraries = context.registry->asset_libraries();
  if (std::find(libraries.begin(), libraries.end(), source) != libraries.end()) {
    return ResolveUserObject(context, source, identifier);
  }
  throw Error("Can't determine license for `objects` with data_source=" + Quoted(source) +
                  " and identifier=" + Quoted(identifier),
              "", "", std::string(identifier));
}

/// The attribution of an object for the scene and grasp listings.
std::string ObjectAttribution(const LicenseContext& context, const std::string& source,
                              const std::string& uid) {
  return ResolveObject(context, source, uid).value("attribution", std::string("unknown"));
}

// ---------------------------------------------------------------------------------------------
// Scenes

/// The scene file of index `index` in an installed PER_FILE scene source, or nullopt.
std::optional<fs::path> SceneFile(const LicenseContext& context, std::string_view source,
                                  long long index, const std::vector<std::string>& archives) {
  const fs::path dir = context.assets_dir / "scenes" / std::string(source);
  std::error_code ec;
  const std::string s(source);
  if (s.find("procthor") != std::string::npos || s.find("holodeck") != std::string::npos) {
    const std::string split = s.substr(s.rfind('-') + 1);
    for (const char* variant : {"_ceiling", ""}) {
      const fs::path file = dir / (split + "_" + std::to_string(index) + variant + ".xml");
      if (fs::is_regular_file(file, ec)) return file;
    }
    return std::nullopt;
  }
  if (s.find("ithor") != std::string::npos) {
    // The first XML of the archive whose numbers include the index (the NumericIndex).
    static const std::regex kNumber("-?\\d+");
    for (const std::string& archive : archives) {
      bool match = false;
      for (auto it = std::sregex_iterator(archive.begin(), archive.end(), kNumber);
           it != std::sregex_iterator(); ++it) {
        match = match || it->str() == std::to_string(index);
      }
      if (!match) continue;
      const auto members = ArchiveMembers(context, "scenes", source, archive);
      if (!members) return std::nullopt;
      for (const std::string& m : *members) {
        if (m.ends_with(".xml") && fs::is_regular_file(dir / m, ec)) return dir / m;
      }
    }
    return std::nullopt;
  }
  throw Error("Missing implementation for " + s +
              " (scene sources are procthor*, holodeck* "
              "or *ithor*)");
}

/// {source: [{identifier, attribution}]} of the objects a scene's metadata references.
Json SceneAssets(const LicenseContext& context, const fs::path& scene) {
  const std::optional<Json> metadata = LoadSceneMetadata(scene);
  std::map<std::string, std::set<std::string>> by_source;
  if (metadata) {
    const Json* objects = Member(*metadata, "objects");
    if (objects != nullptr && objects->is_object()) {
      for (const auto& [name, entry] : objects->items()) {
        const Json* id = Member(entry, "asset_id");
        if (id == nullptr || !id->is_string()) continue;
        const std::string uid = id->get<std::string>();
        if (const auto source = DefaultObjectSource(*context.registry, uid)) {
          by_source[*source].insert(uid);
        }
      }
    }
  }
  Json out = Json::object();
  for (const auto& [source, uids] : by_source) {
    Json list = Json::array();
    for (const std::string& uid : uids) {
      list.push_back(
          Json{{"identifier", uid}, {"attribution", ObjectAttribution(context, source, uid)}});
    }
    out[source] = std::move(list);
  }
  return out;
}

Json ResolveScene(const LicenseContext& context, std::string_view source,
                  std::string_view identifier) {
  const std::vector<std::string> archives = SourceArchiveNames(context, "scenes", source);
  static const std::regex kDigits("\\d+");
  std::smatch match;
  const std::string id(identifier);
  std::string asset_id = id;
  Json assets;
  if (std::regex_search(id, match, kDigits)) {
    const long long index = std::stoll(match.str().substr(0, 18));
    asset_id = std::to_string(index);
    const std::optional<fs::path> scene = SceneFile(context, source, index, archives);
    if (!scene) {
      throw Error("scene " + std::to_string(index) + " of scenes/" + std::string(source) +
                      " is not installed (install it with `mlspaces install --scene`)",
                  (context.assets_dir / "scenes" / std::string(source)).string());
    }
    if (scene->string().find(id) == std::string::npos) {
      throw Error("Non-valid identifier " + id, scene->string());
    }
    assets = SceneAssets(context, *scene);
  } else {
    std::vector<std::string> found;
    for (const std::string& a : archives) {
      if (a.find(id) != std::string::npos) found.push_back(a);
    }
    if (found.empty()) {
      throw Error("No archives for `scenes` " + std::string(source) + " " + id);
    }
    if (found.size() > 1) {
      throw Error("multiple archives for `scenes` " + std::string(source) + " " + id + " (" +
                  found[0] + ", " + found[1] + (found.size() > 2 ? ", ...)" : ")"));
    }
  }
  Json out{{"data_type", "scenes"}, {"data_source", source}, {"asset_id", asset_id}};
  out = Merged(std::move(out), Ai2Fields());
  out["attribution"] = Ai2Attribution("Scene");
  out["scope"] = "Scene composition, layout, non-object-specific textures, and metadata.";
  out["relationship_to_assets"] = "collection";
  out["asset_licenses"] = "Assets are independently licensed; see assets info below for details.";
  out["license_determination"] =
      "Scenes are collections referencing independently licensed assets; CC-BY-4.0 applies only "
      "to scene composition, layout, and metadata.";
  if (assets.is_object() && !assets.empty()) out["assets"] = std::move(assets);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Grasps

/// The original's grasp_targets, from the archive's member list in the tries file.
Json GraspTargets(const LicenseContext& context, std::string_view source,
                  const std::string& identifier) {
  const std::vector<std::string> archives = SourceArchiveNames(context, "grasps", source);
  std::vector<std::string> found;
  for (const std::string& a : archives) {
    if (a.find(identifier) != std::string::npos) found.push_back(a);
  }
  if (found.empty()) {
    throw Error("No archives for `grasps` " + std::string(source) + " " + identifier);
  }
  if (found.size() > 1) {
    throw Error("multiple archives for `grasps` " + std::string(source) + " " + identifier);
  }
  const auto members = ArchiveMembers(context, "grasps", source, found[0]);
  if (!members) return Json::object();
  std::set<std::string> objaverse, thor, ithor;
  for (const std::string& path : *members) {
    if (!path.ends_with("_grasps_filtered.npz") && !path.ends_with("_grasps_filtered.json")) {
      continue;
    }
    std::string target = path.substr(path.rfind('/') + 1);
    target = target.substr(0, target.find("_grasps_"));
    // The original: "<identifier>_" + the second '_'-field of the name without the identifier.
    std::string rest = target;
    for (size_t at; (at = rest.find(identifier)) != std::string::npos;) {
      rest.erase(at, identifier.size());
    }
    std::vector<std::string> fields;
    for (size_t start = 0;;) {
      const size_t end = rest.find('_', start);
      fields.push_back(rest.substr(start, end - start));
      if (end == std::string::npos) break;
      start = end + 1;
    }
    const std::string& second = fields.size() >= 2 ? fields[1] : fields.back();
    std::string name = identifier + "_" + second;
    while (!name.empty() && name.front() == '_') name.erase(0, 1);
    while (!name.empty() && name.back() == '_') name.pop_back();
    const auto annotation = context.registry->GetAnnotation(name);
    const Json* flag = annotation ? Member(annotation->json, "isObjaverse") : nullptr;
    if (flag != nullptr && flag->is_boolean()) {
      (flag->get<bool>() ? objaverse : thor).insert(name);
    } else {
      ithor.insert(name);
    }
  }
  Json out = Json::object();
  auto add = [&](const char* key, const std::set<std::string>& names, auto attribution) {
    if (names.empty()) return;
    Json list = Json::array();
    for (const std::string& n : names) list.push_back(attribution(n));
    out[key] = std::move(list);
  };
  add("objaverse", objaverse, [&](const std::string& n) {
    return Json{{"identifier", n}, {"attribution", ObjectAttribution(context, "objaverse", n)}};
  });
  add("thor", thor, [&](const std::string& n) {
    return Json{{"identifier", n}, {"attribution", Ai2Attribution("Model(s)")}};
  });
  add("ithor builtin", ithor, [&](const std::string& n) {
    return Json{{"identifier", n + " (ithor scene builtin)"},
                {"attribution", Ai2Attribution("Asset(s)")}};
  });
  return out;
}

Json ResolveGrasps(const LicenseContext& context, std::string_view source,
                   std::string_view identifier) {
  const std::string id = ValidateIdentifier(SourceArchiveNames(context, "grasps", source), "grasps",
                                            source, identifier);
  Json out{{"data_type", "grasps"}, {"data_source", source}, {"asset_id", id}};
  out = Merged(std::move(out), Ai2Fields());
  out["attribution"] = Ai2Attribution("Grasps generated");
  out["scope"] =
      "Grasp poses, collision data, and metadata (not the underlying 3D model or object).";
  out["relationship_to_assets"] = "annotation";
  out["asset_licenses"] =
      "Underlying objects are independently licensed; see asset license info for details.";
  out["license_determination"] =
      "Grasp data and metadata are derived or created independently of the assets to which they "
      "apply. CC-BY-4.0 applies only to grasp data and metadata, not object meshes, textures, or "
      "other underlying assets.";
  out["external_target_assets"] = GraspTargets(context, source, id);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Robots

struct RobotLicense {
  const char* match;  ///< substring of the identifier (of the source for rocketbox)
  const char* creator;
  const char* attribution;
  const char* source;
  const char* license;
  const char* uri;
  const char* downloaded;
  const char* modifications;  ///< may be null
};
constexpr RobotLicense kRobotLicenses[] = {
    {"franka", "Franka Robotics", "Developed by Franka Robotics", "mujoco_menagerie/franka_fr3",
     "Apache 2.0",
     "https://github.com/google-deepmind/mujoco_menagerie/blob/main/franka_fr3/LICENSE", "2025",
     "Changed position controller to force controller for hand gripper"},
    {"rby", "Rainbow Robotics", "Copyright 2024-2025 Rainbow Robotics", "RainbowRobotics/rby1-sdk",
     "Apache 2.0", "https://github.com/RainbowRobotics/rby1-sdk/blob/main/LICENSE", "2025",
     "Added holonomic base and removed wheel controller and slider controllers"},
    {"robotiq", "ROS-Industrial", "Copyright (c) 2013, ROS-Industrial",
     "mujoco_menagerie/robotiq_2f85_v4", "BSD-2-Clause License",
     "https://github.com/google-deepmind/mujoco_menagerie/blob/main/robotiq_2f85_v4/LICENSE",
     "2025", nullptr},
    {"rum", "NYU Generalizable Robotics and AI Lab (GRAIL)",
     "Copyright (c) 2026 NYU Generalizable Robotics and AI Lab (GRAIL)", "jeffacce/cap-policy",
     "MIT", "https://github.com/jeffacce/cap-policy/blob/main/LICENSE", "2025", nullptr},
    {"yam", "I2RT Robotics, LLC", "Copyright (c) I2RT Robotics",
     "https://github.com/i2rt-robotics/i2rt/blob/d36027fc50e12d9261f091f9d91c4715bb5e398f/i2rt/"
     "robots/get_robot.py#L129",
     "MIT", "https://github.com/i2rt-robotics/i2rt/blob/main/LICENSE", "2026", nullptr},
    {"g1", "HangZhou YuShu TECHNOLOGY CO.,LTD. (\"Unitree Robotics\")",
     "Copyright (c) 2016-2023 HangZhou YuShu TECHNOLOGY CO.,LTD. (\"Unitree Robotics\")",
     "mujoco_menagerie/unitree_g1", "BSD-3-Clause License",
     "https://github.com/google-deepmind/mujoco_menagerie/blob/main/unitree_g1/LICENSE", "2026",
     nullptr},
    {"rocketbox", "Microsoft", "Copyright (c) 2020 Microsoft", "microsoft/Microsoft-Rocketbox",
     "MIT", "https://github.com/microsoft/Microsoft-Rocketbox/blob/master/LICENSE.md", "2026",
     nullptr},
};

Json ResolveRobot(std::string_view source, std::string_view identifier) {
  const std::string id = identifier.empty() ? std::string(source) : std::string(identifier);
  for (const RobotLicense& r : kRobotLicenses) {
    const std::string_view where = std::string_view(r.match) == "rocketbox" ? source : id;
    if (where.find(r.match) == std::string_view::npos) continue;
    Json out{{"data_type", "robots"},
             {"data_source", source},
             {"asset_id", id},
             {"creator_username", r.creator},
             {"attribution", r.attribution},
             {"source", r.source},
             {"license", r.license},
             {"uri", r.uri},
             {"downloaded", r.downloaded}};
    if (r.modifications != nullptr) out["modifications"] = r.modifications;
    return out;
  }
  throw Error("Got unknown robot " + id, "", "", id);
}

}  // namespace

// =============================================================================================
// Archive names and identifiers

std::optional<fs::path> FindSizeManifest(const LicenseContext& context, std::string_view data_type,
                                         std::string_view source) {
  std::error_code ec;
  const std::string type(data_type), src(source);
  if (!context.assets_dir.empty()) {
    const fs::path linked = context.assets_dir / type / src / kSizeManifestFile;
    if (fs::is_regular_file(linked, ec)) return linked;
  }
  if (context.cache_dir.empty()) return std::nullopt;
  const fs::path base = context.cache_dir / type / src;
  if (!context.assets_dir.empty()) {
    const fs::path install = context.assets_dir / kVersionsManifestFile;
    if (fs::is_regular_file(install, ec)) {
      const Json versions = ParseJsonFile(install);
      const Json* by_type = Member(versions, type);
      const Json* version = by_type != nullptr ? Member(*by_type, src) : nullptr;
      if (version != nullptr && version->is_string()) {
        const fs::path file = base / version->get<std::string>() / kSizeManifestFile;
        if (fs::is_regular_file(file, ec)) return file;
      }
    }
  }
  std::vector<fs::path> found;
  for (fs::directory_iterator it(base, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path file = it->path() / kSizeManifestFile;
    if (fs::is_regular_file(file, ec)) found.push_back(file);
  }
  if (found.size() == 1) return found[0];
  return std::nullopt;
}

std::vector<std::string> SourceArchiveNames(const LicenseContext& context,
                                            std::string_view data_type, std::string_view source) {
  const std::optional<fs::path> manifest = FindSizeManifest(context, data_type, source);
  if (!manifest) {
    throw Error(
        "no size manifest for " + std::string(data_type) + "/" + std::string(source) +
            " (looked for " + std::string(kSizeManifestFile) + " under " +
            (context.assets_dir / data_type / source).string() +
            (context.cache_dir.empty()
                 ? std::string()
                 : " and " + (context.cache_dir / data_type / source).string() + "/<version>") +
            "); is the source installed?",
        context.assets_dir.string());
  }
  const Json json = ParseJsonFile(*manifest);
  if (!json.is_object()) {
    throw Error("expected an object {archive: size in MB}, got " + JsonTypeName(json),
                manifest->string());
  }
  std::vector<std::string> out;
  for (const auto& [name, size] : json.items()) out.push_back(name);
  return out;
}

std::string ArchiveIdentifier(std::string_view archive, std::string_view source) {
  std::string out(archive);
  const std::string prefix = std::string(source) + "_";
  if (out.starts_with(prefix)) out.erase(0, prefix.size());
  if (out.ends_with(".tar.zst")) out.resize(out.size() - 8);
  return out;
}

std::string ValidateIdentifier(const std::vector<std::string>& archives, std::string_view data_type,
                               std::string_view source, std::string_view identifier) {
  for (const std::string& archive : archives) {
    if (archive.find(identifier) == std::string::npos) continue;
    std::string out = archive.substr(0, archive.find('.'));
    const std::string prefix = std::string(source) + "_";
    for (size_t at; (at = out.find(prefix)) != std::string::npos;) out.erase(at, prefix.size());
    return out;
  }
  std::vector<std::string> ids;
  ids.reserve(archives.size());
  for (const std::string& a : archives) ids.push_back(ArchiveIdentifier(a, source));
  std::sort(ids.begin(), ids.end());
  std::string some;
  for (size_t i = 0; i < ids.size() && i < 10; ++i) some += (i ? ", " : "") + ids[i];
  throw Error("identifier=" + Quoted(identifier) + " is not in source=" + Quoted(source) +
                  " (data_type=" + Quoted(data_type) + "); " + std::to_string(ids.size()) +
                  " identifiers" + (ids.empty() ? "" : ": " + some) +
                  (ids.size() > 10 ? ", ... (--list-all prints them all)" : ""),
              "", "", std::string(identifier));
}

// =============================================================================================
// Resolution

Json ResolveLicense(const LicenseContext& context, std::string_view data_type,
                    std::string_view source, std::string_view identifier) {
  if (context.registry == nullptr) throw UsageError("ResolveLicense: no registry");
  if (data_type == "objects") return ResolveObject(context, source, identifier);
  if (data_type == "scenes") return ResolveScene(context, source, identifier);
  if (data_type == "grasps") return ResolveGrasps(context, source, identifier);
  if (data_type == "robots") return ResolveRobot(source, identifier);
  throw Error("Non-valid data_type=" + Quoted(data_type) +
              " (expected objects, scenes, grasps or robots)");
}

std::optional<std::string> DefaultObjectSource(const Registry& registry, std::string_view uid) {
  const auto annotation = registry.GetAnnotation(uid);
  const std::vector<std::string> libraries = registry.asset_libraries();
  auto is_builtin = [](std::string_view name) {
    for (std::string_view b : kBuiltinAssetLibraries) {
      if (b == name) return true;
    }
    return false;
  };
  if (annotation) {
    const Json* flag = Member(annotation->json, "isObjaverse");
    if (flag != nullptr && flag->is_boolean()) {
      return std::string(flag->get<bool>() ? "objaverse" : "thor");
    }
  }
  if (annotation && !annotation->library.empty() && !is_builtin(annotation->library) &&
      std::find(libraries.begin(), libraries.end(), annotation->library) != libraries.end()) {
    return annotation->library;
  }
  if (const std::optional<AssetLocation> where = registry.Locate(uid)) return where->library;
  return std::nullopt;
}

}  // namespace mlspaces
