// A published package's manifest, mlspaces_package.json: what `pack` wrote, every file's size
// and SHA-256, and what each archive holds; and the names of the files a package folder holds
// (docs/resources.md, "A package"). Manifests are plain values.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/library/package_layout.h"  // ExtractFlagName

namespace mlspaces {

// =============================================================================================
// File names in a package folder

inline constexpr std::string_view kPackageManifestFile = "mlspaces_package.json";
inline constexpr int kPackageFormatVersion = 1;
/// The remote size manifest ({archive: size in MB}) and the tries (gzip JSON {archive: trie
/// of member paths}) of the remote layout; pack writes both beside the manifest, and a
/// tries-only source is indexed from the tries (legacy_source.h). See docs/resources.md.
inline constexpr std::string_view kSizeManifestFile = "mjthor_resource_file_to_size_mb.json";
inline constexpr std::string_view kTriesFile = "mjthor_resources_combined_meta.json.gz";
/// The per-archive member listing ({path: {size, sha256}}), shipped inside the archive.
inline constexpr std::string_view kMemberListDir = ".mlspaces/members";

// =============================================================================================
// The manifest

struct MLSPACES_API PackageFile {
  uint64_t size = 0;
  std::string sha256;
};

struct MLSPACES_API PackageArchive {
  std::string name;   ///< file name, "<source>_<nnnnn>.tar.zst"
  uint64_t size = 0;  ///< compressed bytes (what a download costs)
  std::string sha256;
  uint64_t unpacked_bytes = 0;
  uint32_t assets = 0;
  std::string members_file;  ///< path of its member listing inside the archive
  std::string members_sha256;
};

struct MLSPACES_API PackageManifest {
  std::string data_type = "objects";
  std::string name;
  std::string version;
  std::string created_by;
  uint64_t num_assets = 0;
  uint64_t num_grasp_sets = 0;
  uint64_t num_grasps = 0;
  std::vector<std::string> robots;
  std::map<std::string, PackageFile> files;  ///< store files (uid index, metadata)
  std::vector<PackageArchive> archives;      ///< in index order

  std::string Serialize() const;
  /// @throws Error naming `origin` and the JSON pointer of a bad field.
  static PackageManifest Parse(const std::string& json, const std::string& origin);
  static PackageManifest Load(const std::filesystem::path& file);
};

}  // namespace mlspaces
