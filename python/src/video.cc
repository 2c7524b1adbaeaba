// Camera videos of a dataset (docs/dataset.md, "Videos") read back: every frame decoded to RGB
// (decode_video) and what a file holds (video_info), both through datagen::ProbeVideo.
// mlspaces/reader.py decodes an episode's cameras with them on demand.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nanobind/ndarray.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/string.h>

#include "bindings.h"
#include "convert.h"
#include "mlspaces/core/error.h"
#include "mlspaces/datagen/video.h"

namespace mlspaces::python {

namespace {

namespace dg = mlspaces::datagen;

/// Every frame of a video as packed RGB, frame after frame (T*H*W*3 bytes).
struct DecodedVideo {
  std::vector<uint8_t> rgb;
  int64_t frames = 0;
  int width = 0;
  int height = 0;
};

/// Decodes all of `path` without touching Python (the caller releases the GIL).
/// @throws Error naming the file as ProbeVideo does, or when the frame size changes mid-stream.
DecodedVideo Decode(const std::filesystem::path& path) {
  DecodedVideo out;
  dg::ProbeVideo(path, [&](const dg::VideoFrame& frame) {
    if (out.frames == 0) {
      out.width = frame.width;
      out.height = frame.height;
    } else if (frame.width != out.width || frame.height != out.height) {
      throw Error("frame " + std::to_string(frame.index) + " is " + std::to_string(frame.width) +
                      "x" + std::to_string(frame.height) + ", the first was " +
                      std::to_string(out.width) + "x" + std::to_string(out.height),
                  path.string());
    }
    const size_t bytes = static_cast<size_t>(frame.width) * frame.height * 3;
    const size_t at = out.rgb.size();
    out.rgb.resize(at + bytes);
    std::memcpy(out.rgb.data() + at, frame.rgb, bytes);
    ++out.frames;
  });
  return out;
}

/// The frames as a fresh uint8 (T,H,W,3) numpy array owning the bytes (the vector is moved
/// into the array's owner, not copied).
nb::object FramesToNumpy(DecodedVideo video) {
  return OwnedNumpy<uint8_t>(std::move(video.rgb),
                             {static_cast<size_t>(video.frames), static_cast<size_t>(video.height),
                              static_cast<size_t>(video.width), 3});
}

}  // namespace

void BindVideo(nb::module_& m) {
  // decode_video(path): every frame as RGB, a fresh uint8 (T,H,W,3) array (H,W as encoded:
  // multiples of 16). The GIL is released while decoding.
  m.def(
      "decode_video",
      [](const std::filesystem::path& path) {
        DecodedVideo video;
        {
          nb::gil_scoped_release release;
          video = Decode(path);
        }
        return FramesToNumpy(std::move(video));
      },
      nb::arg("path"),
      "Every frame of a video file as a new uint8 numpy array (T, H, W, 3), RGB. Raises "
      "mlspaces.errors.MlspacesError (a ValueError) naming the file for a missing, truncated or "
      "corrupt video.");
  // video_info(path): {frames, width, height, fps, codec}; decodes the whole stream to count
  // the frames (no RGB conversion). The GIL is released while decoding.
  m.def(
      "video_info",
      [](const std::filesystem::path& path) {
        dg::VideoInfo info;
        {
          nb::gil_scoped_release release;
          info = dg::ProbeVideo(path);
        }
        nb::dict out;
        out["frames"] = info.frames;
        out["width"] = info.width;
        out["height"] = info.height;
        out["fps"] = info.fps;
        out["codec"] = info.codec;
        return out;
      },
      nb::arg("path"),
      "What a video file holds: a dict with frames (decoded, not the container's claim), width, "
      "height, fps (0 when the file does not say) and codec. Decodes the whole stream; raises "
      "as decode_video.");
}

}  // namespace mlspaces::python
