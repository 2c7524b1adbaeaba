// The trajectory recorder: writes episodes to HDF5 in the dataset format, one durable file per
// episode as soon as it ends, merged into trajectories_batch_<b>_of_<n>.h5 when the batch ends.
// Schema and guarantees: docs/dataset.md.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/datagen/episode_record.h"

namespace mlspaces::datagen {

struct MLSPACES_API RecorderOptions {
  /// The work item's folder, e.g. <output>/house_0; created if missing.
  std::filesystem::path dir;
  int batch = 1;        ///< 1-based batch number in the file names
  int num_batches = 1;  ///< "..._batch_<batch>_of_<num_batches>"
  /// Deflate level 0-9 for every dataset but obs_scene (0 = uncompressed). Deflate is built
  /// into every HDF5 reader (docs/dataset.md).
  int compression_level = 4;
  /// false (datagen --format lerobot, docs/lerobot.md): no HDF5 at all. Each episode's part is
  /// its EpisodeRecord (EncodeEpisodeRecord) in <batch stem>.parts/traj_<k:08d>.rec, and
  /// Finish() renames <batch stem>.parts to <batch stem>.episodes (batch_file()) instead of
  /// writing the batch file; WriteEpisodeFile makes the HDF5 later.
  bool hdf5 = true;
};

/// The name of a batch's files without extension: "trajectories_batch_<batch>_of_<num_batches>"
/// (.h5 the batch file, .parts the folder of its episode parts until Finish()).
MLSPACES_API std::string BatchFileStem(int batch, int num_batches);

/// Writes the episodes of one work item (scene x batch).
///
/// Write() validates an episode completely, then writes it as traj_<k> (k = its position in the
/// batch, 0-based) to its own part file <batch stem>.parts/traj_<k:08d>.h5: temp file in that
/// folder, flush and close, fsync, rename, fsync the folder. So a crash loses at most the episode
/// being written, and a failed write leaves nothing behind. Finish() copies every part into
/// <dir>/trajectories_batch_<b>_of_<n>.h5 (same atomic procedure) and removes the parts.
///
/// A Recorder opened on a folder whose parts survived a crash continues after them (their
/// episodes count, next_index() is past them) and removes stale temp files.
///
/// Output bytes depend only on the records: no timestamps, fixed file-format version bounds
/// (HDF5 1.8 format), deterministic dataset order. One Recorder per batch; a Recorder is not
/// thread-safe, separate Recorders may run in separate threads.
class MLSPACES_API Recorder {
 public:
  // ===========================================================================================
  // Construction

  /// @throws Error if the folder cannot be created or the options are out of range.
  explicit Recorder(RecorderOptions options);

  // ===========================================================================================
  // Names

  /// The final batch file: <dir>/trajectories_batch_<b>_of_<n>.h5 (without hdf5: the folder
  /// <dir>/trajectories_batch_<b>_of_<n>.episodes of the finished batch's records).
  std::filesystem::path batch_file() const;
  /// The folder holding the per-episode part files until Finish().
  std::filesystem::path parts_dir() const;
  /// The index k the next written episode gets (= episodes written so far in this batch).
  int next_index() const { return static_cast<int>(parts_.size()); }

  /// The video file name of the dataset format: episode_<k:08d>_<camera>_batch_<b>_of_<n>.mp4
  /// (pass "<camera>_depth" for a depth video; docs/dataset.md). Write videos under this name
  /// in dir() before Write().
  std::string VideoFileName(int episode_index, const std::string& camera) const;
  /// The work item's folder (options.dir); valid while the Recorder lives.
  const std::filesystem::path& dir() const { return options_.dir; }

  // ===========================================================================================
  // Writing

  /// Checks `record` (every per-step field has NumSteps() rows, names are valid, flags are
  /// consistent, videos exist, metadata present) and writes it durably as traj_<next_index()>.
  /// @returns the episode's index k. @throws Error naming the field (an HDF5 path) on bad input,
  /// or the file on I/O failure; nothing is left on disk then and next_index() is unchanged.
  int Write(const EpisodeRecord& record);

  /// The provenance JSON (traj_k attribute) of part k < next_index(): what a resumed run reads
  /// to learn which attempt produced each surviving episode. @throws Error naming the part.
  Json PartProvenance(int k) const;

  /// Merges every part into batch_file() (replacing it atomically) and removes the parts.
  /// With no episode, writes nothing and returns false. Afterwards Write() and Finish() throw.
  /// @throws Error on I/O failure; the parts are then kept, and Finish() may be called again.
  bool Finish();

 private:
  RecorderOptions options_;
  std::string stem_;                          // trajectories_batch_<b>_of_<n>
  std::vector<std::filesystem::path> parts_;  // parts_[k] holds traj_k
  bool finished_ = false;
};

/// Writes `record` as traj_<k> alone into the new file `file` (not replaced if it exists), with
/// the bytes that copying traj_<k> out of a batch file into a new file gives (H5Ocopy, HDF5 1.8
/// format bounds: export-lerobot's meta/mlspaces/hdf5/ files). No other file is written.
/// @throws Error naming the field or the file, as Write().
MLSPACES_API void WriteEpisodeFile(const EpisodeRecord& record, int k,
                                   const std::filesystem::path& file, int compression_level = 4);

/// Number of traj_<k> groups in a trajectories file. @throws Error naming the file.
MLSPACES_API int64_t CountEpisodes(const std::filesystem::path& file);

/// Checks a record without writing it (what Write() checks first, except video existence
/// when `video_dir` is empty). @throws Error naming the field (an HDF5 path).
void ValidateEpisode(const EpisodeRecord& record, const std::filesystem::path& video_dir = {});

}  // namespace mlspaces::datagen
