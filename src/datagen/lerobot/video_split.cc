// SplitVideo (video_concat.h): the inverse of VideoConcat's kCopy, for import-lerobot.
#include <cstdio>
#include <memory>
#include <string>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
}

#include "av_util.h"
#include "mlspaces/core/error.h"
#include "video_concat.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;

namespace {

// One episode's MP4, muxed as VideoWriter does (bit-exact flags, the episode's time base).
class Mux {
 public:
  Mux(const fs::path& out, const AVStream* in, AVRational tb) : out_(out) {
    int ret = avformat_alloc_output_context2(&fmt_, nullptr, "mp4", out.c_str());
    if (ret < 0 || fmt_ == nullptr) {
      throw Error("cannot create an MP4 muxer: " + AvError(ret), out.string());
    }
    fmt_->flags |= AVFMT_FLAG_BITEXACT;
    stream_ = avformat_new_stream(fmt_, nullptr);
    if (stream_ == nullptr) throw Error("cannot add a video stream", out.string());
    if ((ret = avcodec_parameters_copy(stream_->codecpar, in->codecpar)) < 0) {
      throw Error("cannot copy codec parameters: " + AvError(ret), out.string());
    }
    stream_->codecpar->codec_tag = 0;
    // The demuxer reports the joined file's mean bit rate; VideoWriter's encoder (crf) has
    // none, and the MP4 muxer writes it into btrt.
    stream_->codecpar->bit_rate = 0;
    stream_->time_base = tb;
    stream_->avg_frame_rate = in->avg_frame_rate;
    tb_ = tb;
    if ((ret = avio_open(&fmt_->pb, out.c_str(), AVIO_FLAG_WRITE)) < 0) {
      throw Error("cannot create the file: " + AvError(ret), out.string());
    }
    if ((ret = avformat_write_header(fmt_, nullptr)) < 0) {
      throw Error("cannot write the MP4 header: " + AvError(ret), out.string());
    }
  }
  ~Mux() {
    if (fmt_ != nullptr) {
      if (fmt_->pb != nullptr) avio_closep(&fmt_->pb);
      avformat_free_context(fmt_);
    }
  }
  Mux(const Mux&) = delete;
  Mux& operator=(const Mux&) = delete;

  void Write(AVPacket* p) {
    p->stream_index = stream_->index;
    p->pos = -1;
    av_packet_rescale_ts(p, tb_, stream_->time_base);
    const int ret = av_interleaved_write_frame(fmt_, p);
    if (ret < 0) throw Error("cannot write a packet: " + AvError(ret), out_.string());
  }
  void Finish() {
    int ret = av_write_trailer(fmt_);
    if (ret < 0) throw Error("cannot finish the MP4: " + AvError(ret), out_.string());
    if ((ret = avio_closep(&fmt_->pb)) < 0) {
      throw Error("cannot close the file: " + AvError(ret), out_.string());
    }
  }

 private:
  fs::path out_;
  AVFormatContext* fmt_ = nullptr;
  AVStream* stream_ = nullptr;
  AVRational tb_{0, 1};
};

}  // namespace

void SplitVideo(const fs::path& joined, const std::vector<VideoSegment>& segments,
                const std::vector<fs::path>& outputs) {
  if (segments.size() != outputs.size())
    throw Error("segments and outputs differ", joined.string());
  AVFormatContext* raw = nullptr;
  int ret = avformat_open_input(&raw, joined.c_str(), nullptr, nullptr);
  if (ret < 0) throw Error("cannot open the video: " + AvError(ret), joined.string());
  std::unique_ptr<AVFormatContext, InputCloser> in(raw);
  if ((ret = avformat_find_stream_info(in.get(), nullptr)) < 0) {
    throw Error("cannot read the video's streams: " + AvError(ret), joined.string());
  }
  const int si = av_find_best_stream(in.get(), AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
  if (si < 0) throw Error("no video stream", joined.string());
  const AVStream* s = in->streams[si];
  std::unique_ptr<AVPacket, PacketFree> pkt(av_packet_alloc());
  size_t e = 0;
  int64_t taken = 0;
  std::unique_ptr<Mux> mux;
  while (e < segments.size()) {
    const VideoSegment& seg = segments[e];
    if (!mux) {
      if (seg.time_base_num <= 0 || seg.time_base_den <= 0 || seg.frames <= 0) {
        throw Error("segment " + std::to_string(e) + " has no time base or frames",
                    joined.string());
      }
      mux = std::make_unique<Mux>(outputs[e], s, AVRational{seg.time_base_num, seg.time_base_den});
      taken = 0;
    }
    if (taken == seg.frames) {
      mux->Finish();
      mux.reset();
      ++e;
      continue;
    }
    ret = av_read_frame(in.get(), pkt.get());
    if (ret < 0) {
      throw Error("ends after " + std::to_string(taken) + " of the " + std::to_string(seg.frames) +
                      " packets of segment " + std::to_string(e) + ": " + AvError(ret),
                  joined.string());
    }
    if (pkt->stream_index != si) {
      av_packet_unref(pkt.get());
      continue;
    }
    const AVRational tb{seg.time_base_num, seg.time_base_den};
    av_packet_rescale_ts(pkt.get(), s->time_base, tb);
    pkt->pts = pkt->pts - seg.offset + seg.start;
    pkt->dts = pkt->dts - seg.offset + seg.start;
    mux->Write(pkt.get());
    av_packet_unref(pkt.get());
    ++taken;
  }
}

}  // namespace mlspaces::datagen::lerobot
