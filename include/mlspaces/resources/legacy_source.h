// MolmoSpaces-format sources: built-in data installed by the ORIGINAL resource manager (a
// cache version folder with the remote manifest, the gzip "tries" file, extracted archives and
// `.<archive>_complete_extract` flags, but none of our stores). BuildLegacyIndex turns the
// tries into our UID index, so the Registry answers lookups on such a source with one hash
// probe instead of scanning its folders (see docs/resources.md, "MolmoSpaces-format sources").
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace mlspaces {

struct LegacyIndexReport {
  size_t assets = 0, archives = 0;
  std::vector<std::string> warnings;  ///< one line each (duplicate UIDs)
  std::filesystem::path index_dir;    ///< <version_dir>/.mlspaces/index
};

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
LegacyIndexReport BuildLegacyIndex(const std::filesystem::path& version_dir,
                                   const std::string& name);

}  // namespace mlspaces
