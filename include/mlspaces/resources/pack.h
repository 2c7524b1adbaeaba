// `mlspaces pack`: a user asset + grasp library -> a published, versioned package. What a
// package holds: docs/resources.md ("A package"); the store layout: docs/formats.md.
#pragma once

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace mlspaces {

// =============================================================================================
// Options and report

struct MLSPACES_API PackOptions {
  std::string name;     ///< source name (default: the library folder's name)
  std::string version;  ///< default: today's UTC date, YYYYMMDD
  std::string data_type = "objects";
  /// Grasp library folder (with grasps_index.json); default: the library folder when it has
  /// one. Empty and absent: no grasps.
  std::filesystem::path grasp_dir;
  uint32_t assets_per_archive = 1;
  int zstd_level = 3;
  int threads = 0;  ///< 0 = hardware concurrency
  bool overwrite = false;
  /// Called as archives finish, in order, on the calling thread: (archives done, total). May
  /// be empty.
  std::function<void(size_t, size_t)> progress;
};

struct MLSPACES_API PackReport {
  std::filesystem::path package_dir;  ///< <out>/<type>/<name>/<version>
  std::string name, version;
  size_t assets = 0, archives = 0, grasp_sets = 0, grasps = 0;
  uint64_t archive_bytes = 0, unpacked_bytes = 0;
  /// What was left out, one warning each (severity kWarning), printed as
  /// Diagnostic::ToString: path = the file left out (a symbolic link; a grasp file of a UID
  /// not in the asset index, with uid = that UID), message = why.
  std::vector<Diagnostic> warnings;
};

// =============================================================================================
// Packing

/// Packs `library_dir` (it must hold assets_index.json) into
/// <out_dir>/<type>/<name>/<version>/ and merges {type: {name: version}} into
/// <out_dir>/mlspaces_sources.json. Written under a temp name and renamed into place, so a
/// crashed pack leaves no half package. Same inputs and options -> same bytes.
/// @throws Error naming the file at fault; UsageError for bad options.
MLSPACES_API PackReport PackLibrary(const std::filesystem::path& library_dir,
                                    const std::filesystem::path& out_dir, PackOptions options);

}  // namespace mlspaces
