// A published package's manifest, mlspaces_package.json: what `pack` wrote, every file's size
// and SHA-256, and what each archive holds.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "mlspaces/library/package_layout.h"  // ExtractFlagName

namespace mlspaces {

inline constexpr std::string_view kPackageManifestFile = "mlspaces_package.json";
inline constexpr int kPackageFormatVersion = 1;
/// The original's remote manifest ({archive: size in MB}) and tries, also written by pack so
/// MolmoSpaces' resource manager can serve an mlspaces package.
inline constexpr std::string_view kOriginalSizeManifestFile =
    "mjthor_resource_file_to_size_mb.json";
inline constexpr std::string_view kOriginalTriesFile = "mjthor_resources_combined_meta.json.gz";
/// The per-archive member listing ({path: {size, sha256}}), shipped inside the archive.
inline constexpr std::string_view kMemberListDir = ".mlspaces/members";

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
