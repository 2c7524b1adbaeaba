// Names of the files in an installed package folder (docs/resources.md, "Packages"):
// what the store reader and the registry open, and what `mlspaces pack`, `install` and
// `index-builtin` (resources) write. One place for both sides so they cannot drift.
#pragma once

#include "mlspaces/core/export.h"

#include <string>
#include <string_view>

namespace mlspaces {

inline constexpr std::string_view kUidIndexFile = "uid_index.mlsx";
inline constexpr std::string_view kMetadataStoreFile = "metadata.mlsm";
/// Where `mlspaces index-builtin` keeps the UID index of a MolmoSpaces-format source (one
/// without stores of its own), inside its version folder. The registry looks there too.
inline constexpr std::string_view kLegacyIndexDir = ".mlspaces/index";
/// Grasp shards live inside the archives, under this folder of the package root.
inline constexpr std::string_view kGraspShardDir = ".mlspaces/grasps";
inline constexpr std::string_view kGraspShardExtension = ".mlsg";

/// The extraction flag of an installed archive, a file in the package folder:
/// ".<name with '/' -> '__'>_complete_extract" (MolmoSpaces' name, shared with its cache).
/// Its presence means the archive is installed; the registry checks it for
/// AssetLocation::installed.
MLSPACES_API std::string ExtractFlagName(const std::string& archive);

/// "foo.tar.zst" -> "foo"; otherwise the name without its last extension.
MLSPACES_API std::string ArchiveStem(const std::string& archive);

/// Path of an archive's grasp shard inside the archive and the package folder:
/// ".mlspaces/grasps/<archive stem>.mlsg" (what pack writes and lookups open).
MLSPACES_API std::string GraspShardMember(const std::string& archive);

}  // namespace mlspaces
