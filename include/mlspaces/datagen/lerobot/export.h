// export-lerobot: an mlspaces dataset (HDF5 + MP4, docs/dataset.md) as a LeRobot v3.0 dataset
// (docs/lerobot.md has the mapping of every array to a feature).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mlspaces/datagen/lerobot/writer.h"

namespace mlspaces::datagen::lerobot {

struct ExportOptions {
  /// The dataset's frame rate must equal this when set (else Error); 0: take the dataset's.
  double fps = 0;
  /// Written nowhere in the files (LeRobot takes it from the caller); kept for messages.
  std::string repo_id;
  VideoCodec codec = VideoCodec::kCopy;
  /// Write meta/mlspaces/ (each episode's HDF5 group unchanged, video cut points, the run's
  /// config, journal and summary), which import-lerobot needs to give the dataset back exactly.
  bool mlspaces_meta = true;
  /// Called after each exported episode with (done, total).
  std::function<void(int64_t, int64_t)> progress;
};

struct ExportReport {
  int64_t episodes = 0;  ///< exported
  int64_t frames = 0;    ///< data rows
  int64_t tasks = 0;
  /// Left out: "<file>: traj_<k>: failed" / "…: truncated", one per episode.
  std::vector<std::string> skipped;
  std::vector<std::string> cameras;  ///< camera names (video keys observation.images.<name>)
  double fps = 0;
};

/// Reads every finished episode of `dataset_dir` (a run folder, a house folder or one batch
/// file's folder, in mlspaces.reader's order), leaves out failed and truncated ones, and
/// writes the LeRobot dataset to `out_dir` through a temp folder beside it renamed into place
/// at the end (a killed run leaves no `out_dir`; the next run removes the stale temp folder).
/// @throws Error (one line naming the file and field) for an `out_dir` that exists, no
/// exportable episode, episodes whose fps, cameras or camera sizes differ, `fps` set and not
/// the dataset's, a video whose frame rate is not the episode's, unreadable files.
ExportReport ExportLeRobot(const std::filesystem::path& dataset_dir,
                           const std::filesystem::path& out_dir, const ExportOptions& options = {});

/// As ExportLeRobot for a run made without HDF5 (datagen --format lerobot: RunOptions::hdf5
/// false): its finished batches' episode records (house_<h>/trajectories_batch_<b>_of_<n>
/// .episodes/traj_<k:08d>.rec) and the MP4s beside them give the bytes ExportLeRobot gives for
/// the HDF5 run of the same config and seed; each record's meta/mlspaces/hdf5/ file is written
/// from it (WriteEpisodeFile) and read back as ExportLeRobot reads a batch file.
/// @throws Error as ExportLeRobot, and naming a record that cannot be read.
ExportReport ExportLeRobotRecords(const std::filesystem::path& run_dir,
                                  const std::filesystem::path& out_dir,
                                  const ExportOptions& options = {});

}  // namespace mlspaces::datagen::lerobot
