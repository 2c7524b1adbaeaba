// mlspaces_package.json: serialise and parse strictly.
#include "mlspaces/resources/package.h"

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"

namespace mlspaces {

namespace {

bool IsHex64(const std::string& s) {
  if (s.size() != 64) return false;
  for (char c : s) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

/// Strict field access: the key must exist with the right type.
class Reader {
 public:
  Reader(const Json& object, std::string origin, std::string pointer)
      : object_(object), origin_(std::move(origin)), pointer_(std::move(pointer)) {
    if (!object_.is_object()) Fail("", "expected an object, got " + JsonTypeName(object_));
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& message) const {
    throw Error(message, origin_, key.empty() ? pointer_ : pointer_ + "/" + JsonPointerToken(key));
  }
  const Json& Get(const std::string& key) const {
    auto it = object_.find(key);
    if (it == object_.end()) Fail(key, "missing field");
    return *it;
  }
  std::string String(const std::string& key) const {
    const Json& v = Get(key);
    if (!v.is_string()) Fail(key, "expected string, got " + JsonTypeWord(v));
    return v.get<std::string>();
  }
  std::string Sha(const std::string& key) const {
    std::string s = String(key);
    if (!IsHex64(s)) Fail(key, "expected a lowercase hex SHA-256");
    return s;
  }
  uint64_t Count(const std::string& key) const {
    const Json& v = Get(key);
    if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<int64_t>() >= 0)) {
      Fail(key, "expected a whole number >= 0, got " + JsonTypeWord(v));
    }
    return v.get<uint64_t>();
  }
  void OnlyKeys(std::initializer_list<const char*> keys) const {
    for (const auto& [key, value] : object_.items()) {
      bool known = false;
      for (const char* k : keys) known = known || key == k;
      if (!known) Fail(key, "unknown field");
    }
  }
  std::string Pointer(const std::string& key) const {
    return pointer_ + "/" + JsonPointerToken(key);
  }

 private:
  const Json& object_;
  std::string origin_, pointer_;
};

}  // namespace

std::string PackageManifest::Serialize() const {
  Json out = Json::object();
  out["format"] = "mlspaces-package";
  out["format_version"] = kPackageFormatVersion;
  out["data_type"] = data_type;
  out["name"] = name;
  out["version"] = version;
  out["created_by"] = created_by;
  out["num_assets"] = num_assets;
  out["num_grasp_sets"] = num_grasp_sets;
  out["num_grasps"] = num_grasps;
  out["robots"] = robots;
  Json files_json = Json::object();
  for (const auto& [file, info] : files)
    files_json[file] = {{"size", info.size}, {"sha256", info.sha256}};
  out["files"] = std::move(files_json);
  Json archives_json = Json::array();
  for (const PackageArchive& a : archives) {
    archives_json.push_back({{"name", a.name},
                             {"size", a.size},
                             {"sha256", a.sha256},
                             {"unpacked_bytes", a.unpacked_bytes},
                             {"assets", a.assets},
                             {"members_file", a.members_file},
                             {"members_sha256", a.members_sha256}});
  }
  out["archives"] = std::move(archives_json);
  return out.dump(1) + "\n";
}

PackageManifest PackageManifest::Parse(const std::string& text, const std::string& origin) {
  const Json doc = ParseJson(text, origin);
  Reader top(doc, origin, "");
  top.OnlyKeys({"format", "format_version", "data_type", "name", "version", "created_by",
                "num_assets", "num_grasp_sets", "num_grasps", "robots", "files", "archives"});
  if (top.String("format") != "mlspaces-package") top.Fail("format", "not an mlspaces package");
  if (top.Count("format_version") != kPackageFormatVersion) {
    top.Fail("format_version",
             "unsupported format version " + std::to_string(top.Count("format_version")) +
                 " (this mlspaces reads " + std::to_string(kPackageFormatVersion) + ")");
  }
  PackageManifest m;
  m.data_type = top.String("data_type");
  m.name = top.String("name");
  m.version = top.String("version");
  m.created_by = top.String("created_by");
  m.num_assets = top.Count("num_assets");
  m.num_grasp_sets = top.Count("num_grasp_sets");
  m.num_grasps = top.Count("num_grasps");
  const Json& robots = top.Get("robots");
  if (!robots.is_array()) top.Fail("robots", "expected array, got " + JsonTypeName(robots));
  for (size_t i = 0; i < robots.size(); ++i) {
    if (!robots[i].is_string()) top.Fail("robots", "expected strings");
    m.robots.push_back(robots[i].get<std::string>());
  }
  const Json& files = top.Get("files");
  Reader files_reader(files, origin, "/files");
  for (const auto& [file, info] : files.items()) {
    Reader r(info, origin, files_reader.Pointer(file));
    r.OnlyKeys({"size", "sha256"});
    m.files[file] = PackageFile{r.Count("size"), r.Sha("sha256")};
  }
  const Json& archives = top.Get("archives");
  if (!archives.is_array()) top.Fail("archives", "expected array, got " + JsonTypeName(archives));
  for (size_t i = 0; i < archives.size(); ++i) {
    Reader r(archives[i], origin, "/archives/" + std::to_string(i));
    r.OnlyKeys(
        {"name", "size", "sha256", "unpacked_bytes", "assets", "members_file", "members_sha256"});
    PackageArchive a;
    a.name = r.String("name");
    if (a.name.empty() || a.name.find('/') != std::string::npos || a.name[0] == '.') {
      r.Fail("name", "archive names must be plain file names");
    }
    a.size = r.Count("size");
    a.sha256 = r.Sha("sha256");
    a.unpacked_bytes = r.Count("unpacked_bytes");
    a.assets = static_cast<uint32_t>(r.Count("assets"));
    a.members_file = r.String("members_file");
    a.members_sha256 = r.Sha("members_sha256");
    m.archives.push_back(std::move(a));
  }
  return m;
}

PackageManifest PackageManifest::Load(const std::filesystem::path& file) {
  return Parse(ReadFile(file), file.string());
}

}  // namespace mlspaces
