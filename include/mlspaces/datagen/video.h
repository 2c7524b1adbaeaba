// H.264 MP4 videos of camera frames (spec 11.2): writing (VideoWriter) and reading back
// (ProbeVideo). FFmpeg (libavformat/libavcodec/libswscale) stays behind this header.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

namespace mlspaces::datagen {

/// How a video is encoded. The defaults are the dataset format's (docs/dataset.md): libx264,
/// yuv420p, crf 25, one frame per 66 ms policy step.
struct MLSPACES_API VideoOptions {
  /// Frames per second; stored as a rational (av_d2q, denominator <= 100000): 1000/66 is
  /// exactly 500/33.
  double fps = 1000.0 / 66.0;
  /// x264 constant rate factor, 0-51 (lower is better and bigger).
  int crf = 25;
  /// x264 preset: ultrafast … placebo. "veryfast" is about 3x faster than x264's default,
  /// "medium", at the same crf, with files of similar size (bench/datagen_video_bench).
  std::string preset = "veryfast";
  /// x264 threads. The bytes depend on it, so it is fixed (never "auto", which would vary with
  /// the machine). 1 suits datagen, which runs one process per core.
  int threads = 1;
};

/// One frame decoded by ProbeVideo: `rgb` is width x height RGB, 3 bytes a pixel, rows top to
/// bottom, no padding; valid only during the callback.
struct MLSPACES_API VideoFrame {
  int64_t index = 0;
  int width = 0;
  int height = 0;
  const unsigned char* rgb = nullptr;
};

/// Writes one H.264 MP4 (libx264 High profile, yuv420p BT.601 limited range, tagged so) from
/// RGB frames.
///
/// Every frame is `width` x `height` RGB, 3 bytes a pixel, rows top to bottom, no padding.
/// A width or height that is not a multiple of 16 is scaled up (bicubic) to the next multiple
/// of 16 (as imageio's macro_block_size=16 does): a 33x17 camera gives a 48x32 video.
/// encoded_width()/encoded_height() say what the file holds.
///
/// Bytes are deterministic: the same frames and options give the same file (fixed x264 thread
/// count, bit-exact muxer and scaler flags, no creation time or library version in the file).
///
/// The file is written to a temp file beside `path` (`<path>.tmp.<pid>.<n>`) and only Finish()
/// renames it into place (after fsync), so the final name never holds a partial MP4. Destroying
/// a writer without a successful Finish() removes the temp file. Not thread-safe; separate
/// writers may be used from separate threads. A moved-from writer may only be destroyed or
/// assigned to.
class MLSPACES_API VideoWriter {
 public:
  // ===========================================================================================
  // Construction

  /// Opens the encoder and the temp file (creating missing parent folders).
  /// @throws Error naming `path` for a size outside 1..16384, bad options (fps <= 0, crf
  /// outside 0..51, unknown preset, threads < 1) or a file that cannot be created.
  VideoWriter(std::filesystem::path path, int width, int height, VideoOptions options = {});
  ~VideoWriter();
  VideoWriter(VideoWriter&&) noexcept;
  VideoWriter& operator=(VideoWriter&&) noexcept;
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  // ===========================================================================================
  // Writing

  /// Encodes one frame (width * height * 3 bytes). @throws Error naming the file on an encoder
  /// or write failure, or after Finish().
  void AddFrame(const unsigned char* rgb);
  /// Flushes the encoder (every frame added is in the file, B-frames included), writes the
  /// trailer, fsyncs, renames into place and fsyncs the folder.
  /// @throws Error naming the file on failure or when no frame was added (the temp file is
  /// removed and nothing is left under `path`).
  void Finish();

  // ===========================================================================================
  // Access

  /// Frames added so far.
  int64_t frames() const;
  /// The size in the file: width and height rounded up to multiples of 16.
  int encoded_width() const;
  int encoded_height() const;
  /// The final path (not the temp file); valid while the writer lives.
  const std::filesystem::path& path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// What ProbeVideo found in a file.
struct MLSPACES_API VideoInfo {
  /// Frames actually decoded (not the container's claim).
  int64_t frames = 0;
  int width = 0;
  int height = 0;
  /// The stream's average frame rate (container), 0 when the file does not say.
  double fps = 0;
  /// Decoder name, e.g. "h264".
  std::string codec;
};

/// Called by ProbeVideo for each decoded frame, in presentation order.
using VideoFrameCallback = std::function<void(const VideoFrame&)>;

/// Opens a video and decodes all of its first video stream, counting frames; with `on_frame`,
/// each frame is also converted to RGB (BT.601 limited range, as written) and passed to it.
/// @throws Error naming the file when it is missing, not a video, truncated or corrupt
/// (bitstream errors are fatal, not concealed), or when fewer frames decode than the
/// container lists.
VideoInfo ProbeVideo(const std::filesystem::path& path, const VideoFrameCallback& on_frame = {});

}  // namespace mlspaces::datagen
