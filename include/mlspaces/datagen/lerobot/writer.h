// Writes a LeRobot v3.0 dataset (docs/lerobot.md): meta/info.json, meta/stats.json,
// meta/tasks.parquet, meta/episodes/chunk-000/file-000.parquet, data/chunk-000/file-000.parquet
// and videos/<camera key>/chunk-000/file-000.mp4, many episodes per file. Episodes are added
// one at a time (export-lerobot reads them from HDF5; a datagen worker can hand its own).
// Parquet goes through Arrow C++; Arrow stays behind this header.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace mlspaces::datagen::lerobot {

/// A numeric per-frame column: `dtype` "float32", "int64" or "bool"; `names` one per value (the
/// feature's shape is (names.size(),); a 1-value feature is a scalar column).
struct Feature {
  std::string key;  ///< e.g. "observation.state"; no '/'
  std::string dtype;
  std::vector<std::string> names;
};

/// A camera stream: the feature `key` ("observation.images.wrist_camera") and its frame size.
struct Camera {
  std::string key;
  int width = 0, height = 0;
};

/// How camera videos get into the dataset: `kCopy` re-muxes the H.264 packets of each episode's
/// MP4 into the camera's file (no re-encoding; every episode's stream must have the same
/// codec parameters), `kH264` decodes and re-encodes them (libx264, VideoOptions defaults),
/// `kAv1` re-encodes them as AV1 (SVT-AV1, LeRobot's default settings).
enum class VideoCodec { kCopy, kH264, kAv1 };

/// What the dataset as a whole is.
struct DatasetInfo {
  double fps = 0;          ///< frames per second of data and videos
  std::string robot_type;  ///< info.json robot_type
  std::vector<Feature> features;
  std::vector<Camera> cameras;
  VideoCodec codec = VideoCodec::kCopy;
};

/// One episode: `length` frames of every feature (row-major, length * names.size() values, as
/// double; bool as 0/1) and, per camera key, its MP4 (at least `length` frames at `fps`; the
/// first `length` are the episode's).
struct EpisodeData {
  std::string task;
  int64_t length = 0;
  std::map<std::string, std::vector<double>> columns;
  std::map<std::string, std::filesystem::path> videos;
};

/// Where an episode's frames of one camera landed in the camera's joined file. For
/// VideoCodec::kCopy also how to cut them out again (import-lerobot): the episode is `frames`
/// packets; a packet's timestamp in the episode's own file (time base `time_base_num` /
/// `time_base_den`) is its joined-file timestamp, in that time base, - `offset` + `start`.
struct VideoSegment {
  double from_s = 0, to_s = 0;  ///< seconds from the joined file's start
  int64_t frames = 0;
  int64_t start = 0, offset = 0;
  int time_base_num = 0, time_base_den = 1;
};

/// Builds one dataset in `dir` (created; must not exist). Nothing in `dir` is complete until
/// Finish() returns: write it into a temp folder and rename it into place afterwards.
class Writer {
 public:
  /// @throws Error for a feature key with '/', a duplicate key, an unknown dtype, fps <= 0.
  Writer(std::filesystem::path dir, DatasetInfo info);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Appends one episode (its frames, its video segments). @throws Error naming the column or
  /// video on a missing/short column, a missing video, a video whose fps, size or codec
  /// parameters differ from the dataset's. @returns the episode's segment per camera, in
  /// DatasetInfo::cameras order.
  std::vector<VideoSegment> Add(const EpisodeData& episode);
  /// Writes the parquet files, stats.json and info.json and closes the videos.
  /// @throws Error when no episode was added or a file cannot be written.
  void Finish();

  int64_t episodes() const;
  int64_t frames() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces::datagen::lerobot
