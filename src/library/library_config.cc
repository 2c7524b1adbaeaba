// Library lists from YAML files and CLI flags. Strict: unknown keys and wrong types are
// errors naming the file and line.
#include "mlspaces/library/library_config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <set>

#include "mlspaces/core/error.h"
#include "mlspaces/library/registry.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

std::string LineOf(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.is_null()) return {};
  return "line " + std::to_string(mark.line + 1);
}

struct YamlReader {
  fs::path file;
  fs::path base_dir;

  [[noreturn]] void Fail(const YAML::Node& node, const std::string& message) const {
    throw Error(message, file.string(), LineOf(node));
  }

  /// A mapping's entries, checking keys are strings, known and not repeated.
  std::vector<std::pair<std::string, YAML::Node>> Entries(
      const YAML::Node& map, const std::vector<std::string>& allowed,
      const std::string& what) const {
    if (!map.IsMap()) Fail(map, what + " must be a mapping");
    std::vector<std::pair<std::string, YAML::Node>> out;
    std::set<std::string> seen;
    for (const auto& kv : map) {
      if (!kv.first.IsScalar()) Fail(kv.first, what + ": keys must be strings");
      const std::string key = kv.first.Scalar();
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        Fail(kv.first, "unknown key '" + key + "' in " + what + " (expected " + list + ")");
      }
      if (!seen.insert(key).second) Fail(kv.first, "duplicate key '" + key + "' in " + what);
      out.emplace_back(key, kv.second);
    }
    return out;
  }

  std::string String(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) {
      Fail(node, "'" + key + "' must be a string, got " +
                     (node.IsNull() ? "null" : node.IsSequence() ? "a list" : "a mapping"));
    }
    if (node.Scalar().empty()) Fail(node, "'" + key + "' must not be empty");
    return node.Scalar();
  }

  std::string Name(const YAML::Node& node, const std::string& key) const {
    std::string name = String(node, key);
    if (name.find('/') != std::string::npos) {
      Fail(node, "library name " + name + " must not contain slashes");
    }
    return name;
  }

  fs::path Path(const YAML::Node& node, const std::string& key) const {
    fs::path p(String(node, key));
    return p.is_absolute() ? p : (base_dir / p).lexically_normal();
  }

  template <class F>
  void List(const YAML::Node& node, const std::string& key, F&& each) const {
    if (node.IsNull()) return;  // "asset_libraries:" with nothing after it
    if (!node.IsSequence()) Fail(node, "'" + key + "' must be a list");
    for (const auto& item : node) each(item);
  }

  void Required(const YAML::Node& map, const std::set<std::string>& present,
                const std::vector<std::string>& keys, const std::string& what) const {
    for (const std::string& k : keys) {
      if (present.count(k) == 0) Fail(map, what + ": missing '" + k + "'");
    }
  }
};

/// Re-throws a registration error with the YAML location when it has none of its own.
template <class F>
void WithLocation(const std::string& file, const std::string& line, F&& f) {
  try {
    f();
  } catch (const UsageError& e) {
    if (!e.path().empty() || file.empty()) throw;
    throw UsageError(e.message(), file, line, e.uid());
  } catch (const Error& e) {
    if (!e.path().empty() || file.empty()) throw;
    throw Error(e.message(), file, line, e.uid());
  }
}

}  // namespace

LibraryConfig LibraryConfig::LoadYaml(const fs::path& file) {
  YamlReader reader{file, fs::absolute(file).parent_path()};
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::BadFile&) {
    throw Error("cannot open the libraries file", file.string());
  } catch (const YAML::ParserException& e) {
    throw Error("invalid YAML: " + e.msg, file.string(),
                e.mark.is_null() ? std::string() : "line " + std::to_string(e.mark.line + 1));
  }
  LibraryConfig config;
  if (root.IsNull()) return config;  // an empty file registers nothing
  for (auto& [key, value] :
       reader.Entries(root, {"assets_dir", "asset_libraries", "grasp_libraries"}, "top level")) {
    if (key == "assets_dir") {
      config.assets_dir = reader.Path(value, key);
    } else if (key == "asset_libraries") {
      reader.List(value, key, [&](const YAML::Node& item) {
        AssetLibrarySpec spec;
        std::set<std::string> present;
        for (auto& [k, v] : reader.Entries(item, {"name", "path"}, "an asset library")) {
          present.insert(k);
          if (k == "name") spec.name = reader.Name(v, k);
          if (k == "path") spec.dir = reader.Path(v, k);
        }
        reader.Required(item, present, {"name", "path"}, "asset library");
        spec.origin_file = file;
        spec.origin_line = LineOf(item);
        config.asset_libraries.push_back(std::move(spec));
      });
    } else {
      reader.List(value, key, [&](const YAML::Node& item) {
        GraspLibrarySpec spec;
        std::set<std::string> present;
        for (auto& [k, v] :
             reader.Entries(item, {"name", "path", "asset_library"}, "a grasp library")) {
          present.insert(k);
          if (k == "name") spec.name = reader.Name(v, k);
          if (k == "path") spec.dir = reader.Path(v, k);
          if (k == "asset_library") spec.asset_library = reader.String(v, k);
        }
        reader.Required(item, present, {"name", "path", "asset_library"}, "grasp library");
        spec.origin_file = file;
        spec.origin_line = LineOf(item);
        config.grasp_libraries.push_back(std::move(spec));
      });
    }
  }
  return config;
}

AssetLibrarySpec LibraryConfig::ParseAssetFlag(const std::string& flag) {
  const size_t eq = flag.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == flag.size()) {
    throw UsageError("--asset-library expects NAME=DIR, got '" + flag + "'");
  }
  AssetLibrarySpec spec;
  spec.name = flag.substr(0, eq);
  spec.dir = flag.substr(eq + 1);
  return spec;
}

GraspLibrarySpec LibraryConfig::ParseGraspFlag(const std::string& flag) {
  const size_t eq = flag.find('=');
  const size_t colon = flag.rfind(':');
  if (eq == std::string::npos || eq == 0 || colon == std::string::npos || colon < eq ||
      colon == eq + 1 || colon + 1 == flag.size()) {
    throw UsageError("--grasp-library expects NAME=DIR:ASSET_LIBRARY, got '" + flag + "'");
  }
  GraspLibrarySpec spec;
  spec.name = flag.substr(0, eq);
  spec.dir = flag.substr(eq + 1, colon - eq - 1);
  spec.asset_library = flag.substr(colon + 1);
  return spec;
}

void LibraryConfig::ApplyTo(Registry& registry) const {
  for (const AssetLibrarySpec& spec : asset_libraries) {
    WithLocation(spec.origin_file.string(), spec.origin_line,
                 [&] { registry.RegisterAssetLibrary(spec.name, spec.dir); });
  }
  for (const GraspLibrarySpec& spec : grasp_libraries) {
    WithLocation(spec.origin_file.string(), spec.origin_line, [&] {
      registry.RegisterGraspLibrary(spec.name, spec.dir, spec.asset_library);
    });
  }
}

}  // namespace mlspaces
