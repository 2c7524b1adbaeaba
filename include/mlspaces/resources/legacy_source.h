// Tries-only ("legacy") sources: built-in data installed without our stores, as a cache
// version folder with the remote size manifest, the gzip tries file (kTriesFile), extracted
// archives and `.<archive>_complete_extract` flags. BuildLegacyIndex turns the tries into our
// UID index, so the Registry answers lookups on such a source with one hash probe instead of
// scanning its folders. Where such sources come from and how duplicates are resolved:
// docs/resources.md (`index-builtin`).
//
// Everything here returns values; nothing keeps a reference to its arguments.
#pragma once

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/export.h"

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace mlspaces {

// =============================================================================================
// Building the index of one source

/// What BuildLegacyIndex wrote and what it left out.
struct MLSPACES_API LegacyIndexReport {
  size_t assets = 0, archives = 0;
  /// Files not indexed, one warning each (severity kWarning), path = the archive name (a key
  /// of the tries file), field = the file's path in it:
  ///  - a file named only ".xml": uid empty, message = why it was ignored;
  ///  - a UID found twice: uid = the UID, path/field = the file ignored, message = "is ignored;
  ///    <archive>: <path> wins" naming the file kept.
  /// Printed as LegacyWarningLine.
  std::vector<Diagnostic> warnings;
  std::filesystem::path index_dir;  ///< <version_dir>/.mlspaces/index
};

/// A warning of LegacyIndexReport on one line: Diagnostic::ToString for one without a UID;
/// "duplicate UID <uid>: <archive>: <path> is ignored; <archive>: <path> wins" for a UID
/// found twice.
MLSPACES_API std::string LegacyWarningLine(const Diagnostic& warning);

/// Reads <version_dir>/mjthor_resources_combined_meta.json.gz (gzip JSON {archive: trie}; a
/// trie is a nested object whose keys are path components or '/'-joined runs of components, a
/// leaf file is {}) and writes uid_index.mlsx + metadata.mlsm into
/// <version_dir>/<kLegacyIndexDir> (".mlspaces/index") with PackedStoreWriter (atomically):
/// archives = the trie keys sorted; every leaf path ending in ".xml" is an asset, UID = file
/// stem, mjcf = the path relative to version_dir, no annotation, no grasps. `name` is the
/// library name recorded in the index. A UID found twice: the first in (archive name, path)
/// order wins, each other one is a warning line naming both paths.
/// @throws Error naming the file (missing, not gzip, truncated, bad JSON, wrong shapes or bad
/// path components with the JSON pointer).
MLSPACES_API LegacyIndexReport BuildLegacyIndex(const std::filesystem::path& version_dir,
                                                const std::string& name);

// =============================================================================================
// Finding the object sources of an assets dir

/// One object source under <assets>/objects, as `index-builtin` finds it.
struct MLSPACES_API ObjectSource {
  enum class Kind {
    kPackage,  ///< has our UID index already (an mlspaces package): nothing to do
    kLegacy,   ///< has the tries file (kTriesFile): BuildLegacySourceIndex indexes it
    kOther,    ///< neither (skipped)
  };
  std::string name;            ///< the folder name
  std::filesystem::path root;  ///< <assets>/objects/<name> (may be a link)
  Kind kind = Kind::kOther;
};

/// The object sources under <assets_dir>/objects: the `names` given, in that order (each must
/// be a folder, or a link to one, holding our UID index or the tries file), or, when `names`
/// is empty, every folder or link to one there, sorted by name.
/// @throws UsageError for a name that is not one folder name; Error naming the path for a
/// named source that is missing or not a source, or a missing objects folder.
MLSPACES_API std::vector<ObjectSource> FindObjectSources(const std::filesystem::path& assets_dir,
                                                         const std::vector<std::string>& names);

/// BuildLegacyIndex of a kLegacy source: its root resolved (links followed) as the version
/// dir, its name as the library name. @throws Error as BuildLegacyIndex, or naming the root
/// when it cannot be resolved.
MLSPACES_API LegacyIndexReport BuildLegacySourceIndex(const ObjectSource& source);

}  // namespace mlspaces
