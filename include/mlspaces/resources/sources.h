// Data sources and where they live: the pinned versions, the cache dir, the install (assets)
// dir of symlinks and the remote base URL (spec section 7). The built-in pins, the variables'
// defaults and where they come from: docs/resources.md ("Data sources and versions").
//
// Everything here returns values; nothing keeps a reference to its arguments.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <map>
#include <optional>
#include <string>

// DefaultAssetsDir, ResolveAssetsDir: the install (assets) dir, in the library layer.
#include "mlspaces/library/assets_dir.h"

namespace mlspaces {

// =============================================================================================
// Versions

/// data type -> source -> pinned version. An empty version means "known, not pinned".
using SourceVersions = std::map<std::string, std::map<std::string, std::string>>;

/// The built-in table: objects thor / objaverse / objathor_metadata, grasps droid /
/// droid_objaverse (pinned), robots and scenes (not pinned); docs/resources.md lists them.
/// The reference is to a static table: valid for the life of the program, never modified.
MLSPACES_API const SourceVersions& BuiltinSourceVersions();

/// Deep-merges a JSON pin file shaped like the table ({"objects": {"thor": "20251117"}}):
/// leaf values override, new types and sources are added; a null leaf removes a source.
/// @throws Error naming the file and the JSON pointer of a bad value.
MLSPACES_API void MergePinFile(SourceVersions& versions, const std::filesystem::path& pin_file);
/// As MergePinFile, from JSON text (a remote listing); `origin` names it in errors.
MLSPACES_API void MergePinJson(SourceVersions& versions, const std::string& json,
                               const std::string& origin);

// =============================================================================================
// Settings: dirs, remote, versions

/// Everything a download or lookup needs to know about the resource dirs.
struct MLSPACES_API ResourceSettings {
  std::filesystem::path cache_dir;   ///< versioned, read-only extracted data
  std::filesystem::path assets_dir;  ///< install dir: <type>/<source> symlinks into the cache
  std::string remote_url;            ///< base URL: <remote>/<type>/<source>/<version>/<file>
  SourceVersions versions;           ///< built-ins, then the pin file
  std::filesystem::path pin_file;    ///< empty when none

  /// From the environment: MLSPACES_CACHE_DIR (default ~/.cache/molmo-spaces-resources),
  /// MLSPACES_ASSETS_DIR (default ~/.cache/mlspaces/assets), MLSPACES_REMOTE_URL (default the
  /// public R2 bucket of the built-in data), MLSPACES_PINNED_ASSETS_FILE. Non-empty arguments
  /// override the environment.
  /// @throws Error when the two dirs overlap or the pin file is missing or bad.
  static ResourceSettings FromEnvironment(const std::string& remote_override = {},
                                          const std::filesystem::path& pin_override = {});

  /// Pinned version of a source, or nullopt when the source is unknown or unpinned.
  std::optional<std::string> Version(const std::string& type, const std::string& source) const;
  /// <cache>/<type>/<source>/<version>
  std::filesystem::path VersionDir(const std::string& type, const std::string& source,
                                   const std::string& version) const;
  /// <remote>/<type>/<source>/<version>/<file>
  std::string Url(const std::string& type, const std::string& source, const std::string& version,
                  const std::string& file) const;
};

}  // namespace mlspaces
