// import-lerobot: a LeRobot v3.0 dataset that mlspaces wrote (export-lerobot, datagen --format
// lerobot) back into the HDF5 + MP4 dataset it came from (docs/lerobot.md, "Import").
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>

namespace mlspaces::datagen::lerobot {

struct ImportReport {
  int64_t episodes = 0;
  int64_t batch_files = 0;
  int64_t videos = 0;
};

/// Writes the exported episodes of `lerobot_dir` as the mlspaces dataset they came from
/// (house_<i>/trajectories_batch_<b>_of_<n>.h5 with the same traj_<k> groups, each episode's
/// MP4s cut back out of the joined camera files, the run's config.yaml, journal and summary)
/// into `out_dir`, through a temp folder renamed into place at the end. `progress(done, total)`
/// after each batch file.
/// @throws Error (one line naming the file) for an `out_dir` that exists, a folder that is not
/// a LeRobot dataset, one not made by mlspaces (no meta/mlspaces/mlspaces.json), one whose
/// videos were re-encoded (--codec h264/av1: its frames are not the episodes' own), and for
/// missing or damaged files.
ImportReport ImportLeRobot(const std::filesystem::path& lerobot_dir,
                           const std::filesystem::path& out_dir,
                           const std::function<void(int64_t, int64_t)>& progress = {});

}  // namespace mlspaces::datagen::lerobot
