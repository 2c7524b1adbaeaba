// validate-dataset of a LeRobot v3.0 folder (docs/lerobot.md, "Checking an export").
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace mlspaces::datagen::lerobot {

struct LeRobotReport {
  int64_t episodes = 0, frames = 0, videos = 0;
  /// One line each: "<file>: <field>: <message>".
  std::vector<std::string> problems;
  bool ok() const { return problems.empty(); }
};

/// Checks `dir` against the v3.0 layout: meta/info.json (codebase_version, fps, features,
/// totals, path templates), meta/tasks.parquet, meta/episodes/*/*.parquet (episode indices
/// 0..n-1, contiguous frame ranges, lengths, totals), the data parquet files (every feature a
/// column of its dtype and shape, no unknown column, episode_index/frame_index/index/timestamp
/// per row, row total), every video file (decodes fully, frame size and rate as info.json says,
/// enough frames for each episode's range), meta/stats.json (min, max, mean, std, count per
/// feature) and, when present, meta/mlspaces/mlspaces.json. Never throws for a bad dataset.
LeRobotReport ValidateLeRobot(const std::filesystem::path& dir);

}  // namespace mlspaces::datagen::lerobot
