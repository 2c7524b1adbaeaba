// Internal to export/import-lerobot: meta/mlspaces/, the part of an mlspaces-made LeRobot
// dataset that LeRobot ignores and import-lerobot reads to give back the HDF5 + MP4 dataset
// exactly (docs/lerobot.md, "Import"): mlspaces.json, hdf5/episode_<i:06d>.h5 (each exported
// traj_<k> group, copied unchanged) and run/ (the run folder's config.yaml, journal*.jsonl,
// summary*.txt).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "mlspaces/core/json.h"
#include "mlspaces/datagen/lerobot/writer.h"

namespace mlspaces::datagen::lerobot {

inline constexpr char kSidecarDir[] = "meta/mlspaces";
inline constexpr char kSidecarJson[] = "meta/mlspaces/mlspaces.json";
inline constexpr int kSidecarVersion = 1;

struct SidecarVideo {
  std::string file;  ///< the episode's MP4 name beside its batch file
  VideoSegment segment;
};

struct SidecarEpisode {
  std::string file;  ///< the batch file, relative to the dataset folder ("house_0/…h5")
  std::string traj;  ///< "traj_<k>"
  std::string hdf5;  ///< relative to kSidecarDir: "hdf5/episode_<i:06d>.h5"
  std::map<std::string, SidecarVideo> videos;  ///< by video key
};

struct Sidecar {
  VideoCodec codec = VideoCodec::kCopy;
  std::vector<SidecarEpisode> episodes;
  std::vector<std::string> run_files;  ///< names under run/
};

/// Copies group `traj` of `src` into a new file `dst` (HDF5 1.8 format bounds, as the recorder).
void CopyTrajectories(const std::vector<std::pair<std::filesystem::path, std::string>>& sources,
                      const std::filesystem::path& dst);
/// Copies the run folder's config.yaml, journal*.jsonl and summary*.txt of `run_dir` into
/// `root`/meta/mlspaces/run/; @returns their names (sorted).
std::vector<std::string> CopyRunFiles(const std::filesystem::path& run_dir,
                                      const std::filesystem::path& root);
Json SidecarToJson(const Sidecar& s);
/// @throws Error naming `path` and the field on a malformed mlspaces.json.
Sidecar SidecarFromJson(const Json& j, const std::string& path);
const char* CodecName(VideoCodec c);

}  // namespace mlspaces::datagen::lerobot
