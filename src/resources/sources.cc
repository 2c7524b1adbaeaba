// Data sources: the pinned table, pin files, and the resource dirs from the environment.
#include "mlspaces/resources/sources.h"

#include <cstdlib>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/resources/fetch.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

// The original's R2 bucket (spec 7.4): <base>/<type>/<source>/<version>/<file>.
constexpr const char* kDefaultRemote = "https://pub-3555e9bb2d304fab9c6c79819e48aa40.r2.dev";

std::string Env(const char* name) {
  const char* value = std::getenv(name);
  return value == nullptr ? std::string() : std::string(value);
}

fs::path Home() {
  std::string home = Env("HOME");
  return home.empty() ? fs::path("/tmp") : fs::path(home);
}

/// True when `inner` is `outer` or lies inside it (lexically, after making both absolute).
bool Inside(const fs::path& inner, const fs::path& outer) {
  const fs::path a = fs::weakly_canonical(fs::absolute(inner));
  const fs::path b = fs::weakly_canonical(fs::absolute(outer));
  auto ai = a.begin();
  for (auto bi = b.begin(); bi != b.end(); ++bi, ++ai) {
    if (bi->empty()) continue;
    if (ai == a.end() || *ai != *bi) return false;
  }
  return true;
}

}  // namespace

const SourceVersions& BuiltinSourceVersions() {
  // The original's DATA_TYPE_TO_SOURCE_TO_VERSION at molmospaces 1320b26 for objects and
  // grasps. Robot and scene sources are known by name and left unpinned (pin them in a pin
  // file to install them): a pinned source is one every UID lookup may have to list.
  static const SourceVersions kTable = {
      {"objects",
       {{"thor", "20251117"}, {"objaverse", "20260131"}, {"objathor_metadata", "20260129"}}},
      {"grasps", {{"droid", "20251116"}, {"droid_objaverse", "20251218"}}},
      {"robots", {{"franka_droid", ""}}},
      {"scenes",
       {{"ithor", ""},
        {"procthor-10k", ""},
        {"procthor-objaverse", ""},
        {"holodeck-objaverse", ""}}},
  };
  return kTable;
}

void MergePinJson(SourceVersions& versions, const std::string& text, const std::string& origin) {
  const Json doc = ParseJson(text, origin);
  if (!doc.is_object()) {
    throw Error("expected an object {data_type: {source: version}}, got " + JsonTypeName(doc),
                origin);
  }
  SourceVersions merged = versions;
  for (const auto& [type, sources] : doc.items()) {
    const std::string type_ptr = "/" + JsonPointerToken(type);
    if (!sources.is_object()) {
      throw Error("expected an object {source: version}, got " + JsonTypeName(sources), origin,
                  type_ptr);
    }
    for (const auto& [source, version] : sources.items()) {
      const std::string ptr = type_ptr + "/" + JsonPointerToken(source);
      if (source.empty() || source.find('/') != std::string::npos) {
        throw Error("source names must be non-empty and without '/'", origin, ptr);
      }
      if (version.is_null()) {
        merged[type].erase(source);
      } else if (version.is_string() && !version.get<std::string>().empty() &&
                 version.get<std::string>().find('/') == std::string::npos) {
        merged[type][source] = version.get<std::string>();
      } else {
        throw Error("expected a version string (or null to remove the source), got " +
                        JsonTypeName(version),
                    origin, ptr);
      }
    }
  }
  versions = std::move(merged);
}

void MergePinFile(SourceVersions& versions, const fs::path& pin_file) {
  if (!IsFile(pin_file)) {
    throw Error("Could not find pinned assets file: " + pin_file.string(), pin_file.string());
  }
  MergePinJson(versions, ReadFile(pin_file), pin_file.string());
}

ResourceSettings ResourceSettings::FromEnvironment(const std::string& remote_override,
                                                   const fs::path& pin_override) {
  ResourceSettings s;
  const std::string cache = Env("MLSPACES_CACHE_DIR");
  s.cache_dir = cache.empty() ? Home() / ".cache" / "molmo-spaces-resources" : fs::path(cache);
  s.assets_dir = ResolveAssetsDir().dir;
  s.cache_dir = fs::absolute(s.cache_dir).lexically_normal();
  s.assets_dir = fs::absolute(s.assets_dir).lexically_normal();
  if (Inside(s.cache_dir, s.assets_dir) && Inside(s.assets_dir, s.cache_dir)) {
    throw Error("symlink_dir and cache_dir resolve to the same path: " + s.cache_dir.string());
  }
  if (Inside(s.assets_dir, s.cache_dir)) {
    throw Error("assets dir " + s.assets_dir.string() + " is inside cache dir " +
                s.cache_dir.string() + " (MLSPACES_ASSETS_DIR / MLSPACES_CACHE_DIR)");
  }
  if (Inside(s.cache_dir, s.assets_dir)) {
    throw Error("cache dir " + s.cache_dir.string() + " is inside assets dir " +
                s.assets_dir.string() + " (MLSPACES_CACHE_DIR / MLSPACES_ASSETS_DIR)");
  }
  s.remote_url = !remote_override.empty() ? remote_override : Env("MLSPACES_REMOTE_URL");
  if (s.remote_url.empty()) s.remote_url = kDefaultRemote;
  if (s.remote_url.rfind("http://", 0) != 0 && s.remote_url.rfind("https://", 0) != 0 &&
      s.remote_url.rfind("file://", 0) != 0) {
    // A plain folder is accepted as a local remote.
    s.remote_url = FileUrl(fs::absolute(s.remote_url));
  }
  s.versions = BuiltinSourceVersions();
  s.pin_file = !pin_override.empty() ? pin_override : fs::path(Env("MLSPACES_PINNED_ASSETS_FILE"));
  if (!s.pin_file.empty()) MergePinFile(s.versions, s.pin_file);
  return s;
}

std::optional<std::string> ResourceSettings::Version(const std::string& type,
                                                     const std::string& source) const {
  auto t = versions.find(type);
  if (t == versions.end()) return std::nullopt;
  auto v = t->second.find(source);
  if (v == t->second.end() || v->second.empty()) return std::nullopt;
  return v->second;
}

fs::path ResourceSettings::VersionDir(const std::string& type, const std::string& source,
                                      const std::string& version) const {
  return cache_dir / type / source / version;
}

std::string ResourceSettings::Url(const std::string& type, const std::string& source,
                                  const std::string& version, const std::string& file) const {
  return JoinUrl(remote_url, type + "/" + source + "/" + version + "/" + file);
}

}  // namespace mlspaces
