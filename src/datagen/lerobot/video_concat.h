// Internal to the LeRobot writer: one camera's episodes joined into one MP4, by re-muxing
// their H.264 packets (no re-encoding) or by decoding and re-encoding them (libx264), and the
// per-channel pixel statistics LeRobot's stats.json holds for a video feature.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "mlspaces/datagen/lerobot/writer.h"

namespace mlspaces::datagen::lerobot {

/// How often each 8-bit value occurs, per RGB channel, over the pixels of the sampled frames
/// (exact min, max, mean and std follow; values scaled to [0, 1] by the writer).
struct PixelStats {
  std::array<std::array<uint64_t, 256>, 3> histogram{};
  int64_t frames = 0;  ///< frames sampled
  /// Adds one RGB frame (3 bytes a pixel, rows `stride` bytes apart).
  void Add(const unsigned char* rgb, int width, int height, int stride);
};

/// Frames of an episode's video that go into the pixel stats: every one up to this many, else
/// this many spread evenly (as LeRobot samples frames for its image stats).
inline constexpr int64_t kStatsFramesPerEpisode = 20;

using Segment = VideoSegment;

/// Cuts the joined file `joined` (written with VideoCodec::kCopy) back into one MP4 per
/// episode: `segments[i]` (in file order) goes to `outputs[i]`, the same packets with the
/// episode's own timestamps, muxed as VideoWriter muxes. @throws Error naming the file when it
/// is unreadable or holds fewer packets than the segments.
void SplitVideo(const std::filesystem::path& joined, const std::vector<VideoSegment>& segments,
                const std::vector<std::filesystem::path>& outputs);

class VideoConcat {
 public:
  /// Writes `out` (its folder is created); `fps` is the dataset's rate.
  VideoConcat(std::filesystem::path out, VideoCodec codec, double fps);
  ~VideoConcat();
  VideoConcat(const VideoConcat&) = delete;
  VideoConcat& operator=(const VideoConcat&) = delete;

  /// Appends every frame of `episode_mp4` and adds the pixels of up to kStatsFramesPerEpisode
  /// of them to `stats`. @throws Error naming
  /// the file when it is unreadable, its fps is not the dataset's (within 0.01), its size or
  /// (kCopy) codec parameters differ from the first episode's.
  Segment Append(const std::filesystem::path& episode_mp4, PixelStats& stats);
  /// Finishes the file (trailer). @throws Error on a write failure.
  void Finish();
  int width() const;
  int height() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces::datagen::lerobot
