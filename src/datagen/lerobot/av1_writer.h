// Internal to the LeRobot writer: an AV1 MP4 from RGB frames (SVT-AV1 through FFmpeg; libaom
// for frames under 64x64, which SVT-AV1 refuses), for `export-lerobot --codec av1`. LeRobot
// writes AV1 (libsvtav1, crf 30, GOP 2, yuv420p) by default; these are its settings.
#pragma once

#include <filesystem>
#include <memory>

namespace mlspaces::datagen::lerobot {

class Av1Writer {
 public:
  /// Opens the encoder and `path` (written in place: the export's folder is a temp folder).
  /// @throws Error naming `path` when no AV1 encoder is available or the file cannot be made.
  Av1Writer(std::filesystem::path path, int width, int height, double fps);
  ~Av1Writer();
  Av1Writer(const Av1Writer&) = delete;
  Av1Writer& operator=(const Av1Writer&) = delete;
  /// Encodes one width x height RGB frame (3 bytes a pixel, no padding). @throws Error.
  void AddFrame(const unsigned char* rgb);
  /// Flushes the encoder and writes the trailer. @throws Error.
  void Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces::datagen::lerobot
