// Internal to the LeRobot code: FFmpeg error text and deleters shared by the video files.
#pragma once

#include <string>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
}

namespace mlspaces::datagen::lerobot {

/// FFmpeg's text for error code `ret`.
inline std::string AvError(int ret) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(ret, buf, sizeof buf);
  return buf;
}

/// Deleters for std::unique_ptr of an opened input and a packet.
struct InputCloser {
  void operator()(AVFormatContext* c) const { avformat_close_input(&c); }
};
struct PacketFree {
  void operator()(AVPacket* p) const { av_packet_free(&p); }
};

}  // namespace mlspaces::datagen::lerobot
