// Which libraries to register: from CLI flags or a YAML file.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace YAML {
class Node;
}

namespace mlspaces {

class Registry;
class YamlReader;

struct MLSPACES_API AssetLibrarySpec {
  std::string name;
  std::filesystem::path dir;
  std::filesystem::path origin_file;  ///< the YAML it came from (empty for flags)
  std::string origin_line;            ///< "line N" in origin_file
};

struct MLSPACES_API GraspLibrarySpec {
  std::string name;  ///< root name; robots are appended at registration
  std::filesystem::path dir;
  std::string asset_library;
  std::filesystem::path origin_file;  ///< the YAML it came from (empty for flags)
  std::string origin_line;            ///< "line N" in origin_file
};

/// A list of libraries to register, in order. YAML form (unknown keys are errors, relative
/// paths are relative to the YAML file's folder):
///
///     assets_dir: /data/mlspaces/assets      # optional, like MLSPACES_ASSETS_DIR
///     asset_libraries:
///       - {name: custom_assets, path: asset_library}
///     grasp_libraries:
///       - {name: custom_grasps, path: asset_library, asset_library: custom_assets}
struct MLSPACES_API LibraryConfig {
  std::optional<std::filesystem::path> assets_dir;
  std::vector<AssetLibrarySpec> asset_libraries;
  std::vector<GraspLibrarySpec> grasp_libraries;

  /// @throws Error with file and line for bad YAML, unknown keys, wrong types.
  static LibraryConfig LoadYaml(const std::filesystem::path& file);
  /// Parses "NAME=DIR". @throws UsageError.
  static AssetLibrarySpec ParseAssetFlag(const std::string& flag);
  /// Parses "NAME=DIR:ASSET_LIBRARY" (the last ':' splits). @throws UsageError.
  static GraspLibrarySpec ParseGraspFlag(const std::string& flag);

  /// Registers asset libraries, then grasp libraries, in order. @throws Error; errors without
  /// a file of their own name the YAML file and line of the entry.
  void ApplyTo(Registry& registry) const;
};

// Field descriptions for the YAML archive (core/yaml_archive.h): the keys of the YAML form.

template <class A>
void SerializeFields(A* a, AssetLibrarySpec& spec) {
  a->Visit("name", spec.name);
  a->Visit("path", spec.dir);
}

template <class A>
void SerializeFields(A* a, GraspLibrarySpec& spec) {
  a->Visit("name", spec.name);
  a->Visit("path", spec.dir);
  a->Visit("asset_library", spec.asset_library);
}

template <class A>
void SerializeFields(A* a, LibraryConfig& config) {
  a->Visit("assets_dir", config.assets_dir);
  a->Visit("asset_libraries", config.asset_libraries);
  a->Visit("grasp_libraries", config.grasp_libraries);
}

/// Archive read hooks: a spec needs every key, a non-empty name without slashes, and records
/// the file and line it came from; a LibraryConfig inside another config is a mapping or the
/// path of a libraries YAML file (LoadYaml).
MLSPACES_API void ReadYaml(const YamlReader& reader, const YAML::Node& node, const std::string& key,
                           AssetLibrarySpec& spec);
MLSPACES_API void ReadYaml(const YamlReader& reader, const YAML::Node& node, const std::string& key,
                           GraspLibrarySpec& spec);
MLSPACES_API void ReadYaml(const YamlReader& reader, const YAML::Node& node, const std::string& key,
                           LibraryConfig& config);

}  // namespace mlspaces
