// Grasp libraries: grasps_index.json and building it from a folder (schema and bytes as
// MolmoSpaces writes them; docs/formats.md).
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <map>
#include <string>

#include "mlspaces/library/asset_index.h"

namespace mlspaces {

/// A parsed grasps_index.json. Paths are relative to the grasp-library root.
struct MLSPACES_API GraspIndex {
  /// robot -> uid -> path of grasps.npz
  std::map<std::string, std::map<std::string, std::string>> grasp_paths;
  /// robot -> uid -> joint name (as in the asset MJCF) -> path of joint_grasps_<joint>.npz
  std::map<std::string, std::map<std::string, std::map<std::string, std::string>>>
      articulated_grasp_paths;

  /// Robots named in either map, sorted.
  std::vector<std::string> robots() const;

  /// Parses grasps_index.json; missing top-level keys default to {}. @throws Error with the
  /// file and JSON pointer of a bad field.
  static GraspIndex Load(const std::filesystem::path& index_file);
  /// "articulated_grasp_paths" then "grasp_paths", sorted,
  /// indent 4, no trailing newline.
  std::string Serialize() const;
};

struct MLSPACES_API GraspIndexOptions {
  std::filesystem::path output;  ///< default: <dir>/grasps_index.json
  bool overwrite = false;
};

/// Scans `dir` for `<uid>/<robot>/grasps.npz` and `<uid>/<robot>/joint_grasps_<joint>.npz`.
/// A grasps file less than two folders deep, an empty joint name or the same (robot, uid)
/// found twice, or a grasps file that is a broken symbolic link, is an error naming the files.
MLSPACES_API GraspIndex BuildGraspIndex(const std::filesystem::path& dir, IndexReport* report);

/// `mlspaces index-grasps`. @throws Error (existing output without overwrite, ...).
MLSPACES_API IndexReport WriteGraspIndex(const std::filesystem::path& dir,
                                         const GraspIndexOptions& options);

}  // namespace mlspaces
