#include "video_concat.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <utility>
#include <vector>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libswscale/swscale.h>
}

#include "av1_writer.h"
#include "av_util.h"
#include "mlspaces/core/error.h"
#include "mlspaces/datagen/video.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;

namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// Which of `n` frames go into the pixel stats.
std::vector<bool> StatsSample(int64_t n) {
  std::vector<bool> take(static_cast<size_t>(std::max<int64_t>(n, 0)), n <= kStatsFramesPerEpisode);
  if (n > kStatsFramesPerEpisode) {
    for (int64_t j = 0; j < kStatsFramesPerEpisode; ++j) {
      take[static_cast<size_t>(j * n / kStatsFramesPerEpisode)] = true;
    }
  }
  return take;
}

struct CodecFree {
  void operator()(AVCodecContext* c) const { avcodec_free_context(&c); }
};
struct FrameFree {
  void operator()(AVFrame* f) const { av_frame_free(&f); }
};
struct SwsFree {
  void operator()(SwsContext* c) const { sws_freeContext(c); }
};

}  // namespace

void PixelStats::Add(const unsigned char* rgb, int width, int height, int stride) {
  for (int y = 0; y < height; ++y) {
    const unsigned char* row = rgb + static_cast<ptrdiff_t>(y) * stride;
    for (int x = 0; x < width; ++x) {
      ++histogram[0][row[3 * x]];
      ++histogram[1][row[3 * x + 1]];
      ++histogram[2][row[3 * x + 2]];
    }
  }
  ++frames;
}

struct VideoConcat::Impl {
  fs::path out;
  VideoCodec codec;
  double fps;
  int width = 0, height = 0;
  // kCopy
  AVFormatContext* mux = nullptr;
  AVStream* stream = nullptr;
  AVRational in_tb{0, 1};
  std::vector<uint8_t> extradata;
  int64_t offset = 0;  // in in_tb: where the next episode starts
  int64_t last_dts = INT64_MIN;
  // kH264, kAv1
  std::optional<VideoWriter> writer;
  std::unique_ptr<Av1Writer> av1;
  int64_t frames = 0;

  ~Impl() {
    if (mux != nullptr) {
      if (mux->pb != nullptr) avio_closep(&mux->pb);
      avformat_free_context(mux);
    }
  }

  void OpenMux(const AVStream* in, const fs::path& source) {
    int ret = avformat_alloc_output_context2(&mux, nullptr, "mp4", out.c_str());
    if (ret < 0) throw Error("cannot create an MP4 muxer: " + AvError(ret), out.string());
    mux->flags |= AVFMT_FLAG_BITEXACT;
    stream = avformat_new_stream(mux, nullptr);
    if (stream == nullptr) throw Error("cannot add a video stream", out.string());
    if ((ret = avcodec_parameters_copy(stream->codecpar, in->codecpar)) < 0) {
      throw Error("cannot copy codec parameters: " + AvError(ret), source.string());
    }
    stream->codecpar->codec_tag = 0;
    stream->time_base = in->time_base;
    stream->avg_frame_rate = in->avg_frame_rate;
    stream->r_frame_rate = in->r_frame_rate;
    in_tb = in->time_base;
    if ((ret = avio_open(&mux->pb, out.c_str(), AVIO_FLAG_WRITE)) < 0) {
      throw Error("cannot create the file: " + AvError(ret), out.string());
    }
    if ((ret = avformat_write_header(mux, nullptr)) < 0) {
      throw Error("cannot write the MP4 header: " + AvError(ret), out.string());
    }
  }

  // The sampled frames of the episode's packets (decode order) into `stats`; @returns frames.
  int64_t DecodeStats(const AVCodecParameters* par, const std::vector<AVPacket*>& packets,
                      PixelStats& stats, const fs::path& path) {
    const AVCodec* codec = avcodec_find_decoder(par->codec_id);
    if (codec == nullptr) throw Error("no decoder for the video's codec", path.string());
    std::unique_ptr<AVCodecContext, CodecFree> dec(avcodec_alloc_context3(codec));
    int ret = avcodec_parameters_to_context(dec.get(), par);
    if (ret >= 0) {
      dec->thread_count = 1;
      ret = avcodec_open2(dec.get(), codec, nullptr);
    }
    if (ret < 0) throw Error("cannot open the decoder: " + AvError(ret), path.string());
    const std::vector<bool> take = StatsSample(static_cast<int64_t>(packets.size()));
    std::unique_ptr<AVFrame, FrameFree> frame(av_frame_alloc());
    std::unique_ptr<SwsContext, SwsFree> sws;
    std::vector<unsigned char> rgb;
    int64_t n = 0;
    auto drain = [&] {
      while ((ret = avcodec_receive_frame(dec.get(), frame.get())) >= 0) {
        if (static_cast<size_t>(n) < take.size() && take[static_cast<size_t>(n)]) {
          const int w = frame->width, h = frame->height;
          sws.reset(sws_getCachedContext(
              sws.release(), w, h, static_cast<AVPixelFormat>(frame->format), w, h,
              AV_PIX_FMT_RGB24, SWS_BILINEAR, nullptr, nullptr, nullptr));
          if (!sws) throw Error("cannot convert the frames to RGB", path.string());
          rgb.resize(static_cast<size_t>(w) * h * 3);
          uint8_t* dst[4] = {rgb.data(), nullptr, nullptr, nullptr};
          int dst_stride[4] = {3 * w, 0, 0, 0};
          sws_scale(sws.get(), frame->data, frame->linesize, 0, h, dst, dst_stride);
          stats.Add(rgb.data(), w, h, 3 * w);
        }
        ++n;
        av_frame_unref(frame.get());
      }
      if (ret != AVERROR(EAGAIN) && ret != AVERROR_EOF) {
        throw Error("cannot decode the video: " + AvError(ret), path.string());
      }
    };
    for (AVPacket* q : packets) {
      if ((ret = avcodec_send_packet(dec.get(), q)) < 0) {
        throw Error("cannot decode the video: " + AvError(ret), path.string());
      }
      drain();
    }
    avcodec_send_packet(dec.get(), nullptr);
    drain();
    return n;
  }

  Segment Copy(const fs::path& path, PixelStats& stats) {
    AVFormatContext* raw = nullptr;
    int ret = avformat_open_input(&raw, path.c_str(), nullptr, nullptr);
    if (ret < 0) throw Error("cannot open the video: " + AvError(ret), path.string());
    std::unique_ptr<AVFormatContext, InputCloser> in(raw);
    if ((ret = avformat_find_stream_info(in.get(), nullptr)) < 0) {
      throw Error("cannot read the video's streams: " + AvError(ret), path.string());
    }
    const int si = av_find_best_stream(in.get(), AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
    if (si < 0) throw Error("no video stream", path.string());
    const AVStream* s = in->streams[si];
    const AVCodecParameters* p = s->codecpar;
    const double rate = av_q2d(s->avg_frame_rate);
    if (std::abs(rate - fps) > 0.01) {
      throw Error("frame rate " + Num(rate) + " is not the dataset's " + Num(fps), path.string());
    }
    const std::vector<uint8_t> extra(p->extradata, p->extradata + p->extradata_size);
    if (mux == nullptr) {
      width = p->width;
      height = p->height;
      extradata = extra;
      OpenMux(s, path);
    } else if (p->width != width || p->height != height) {
      throw Error("frame size " + std::to_string(p->width) + "x" + std::to_string(p->height) +
                      " differs from the first episode's " + std::to_string(width) + "x" +
                      std::to_string(height),
                  path.string());
    } else if (p->codec_id != stream->codecpar->codec_id || extra != extradata ||
               s->time_base.num != in_tb.num || s->time_base.den != in_tb.den) {
      throw Error(
          "codec parameters differ from the first episode's video; export with --codec h264 "
          "to re-encode",
          path.string());
    }
    std::unique_ptr<AVPacket, PacketFree> pkt(av_packet_alloc());
    int64_t start = INT64_MAX, end = INT64_MIN, count = 0;
    std::vector<AVPacket*> packets;  // read all first: the episode's first pts is its start
    struct Freer {
      std::vector<AVPacket*>& v;
      ~Freer() {
        for (AVPacket* q : v) av_packet_free(&q);
      }
    } freer{packets};
    while ((ret = av_read_frame(in.get(), pkt.get())) >= 0) {
      if (pkt->stream_index == si) {
        if (pkt->pts == AV_NOPTS_VALUE || pkt->dts == AV_NOPTS_VALUE || pkt->duration <= 0) {
          throw Error("a packet without timestamps or duration", path.string());
        }
        start = std::min(start, pkt->pts);
        end = std::max(end, pkt->pts + pkt->duration);
        packets.push_back(av_packet_clone(pkt.get()));
        ++count;
      }
      av_packet_unref(pkt.get());
    }
    if (ret != AVERROR_EOF) throw Error("cannot read the video: " + AvError(ret), path.string());
    if (count == 0) throw Error("the video has no frames", path.string());
    if (DecodeStats(p, packets, stats, path) != count) {
      throw Error("fewer frames decode than the file lists", path.string());
    }
    Segment seg;
    seg.from_s = static_cast<double>(offset) * av_q2d(in_tb);
    for (AVPacket* q : packets) {
      q->pts = q->pts - start + offset;
      q->dts = q->dts - start + offset;
      if (q->dts <= last_dts) {
        throw Error(
            "its decoding order does not continue the previous episode's; export with --codec "
            "h264 to re-encode",
            path.string());
      }
      last_dts = q->dts;
      q->stream_index = stream->index;
      q->pos = -1;
      av_packet_rescale_ts(q, in_tb, stream->time_base);
      if ((ret = av_interleaved_write_frame(mux, q)) < 0) {
        throw Error("cannot write a packet: " + AvError(ret), out.string());
      }
    }
    seg.start = start;
    seg.offset = offset;
    seg.time_base_num = in_tb.num;
    seg.time_base_den = in_tb.den;
    offset += end - start;
    seg.to_s = static_cast<double>(offset) * av_q2d(in_tb);
    seg.frames = count;
    return seg;
  }
};

VideoConcat::VideoConcat(fs::path out, VideoCodec codec, double fps) : impl_(new Impl) {
  impl_->out = std::move(out);
  impl_->codec = codec;
  impl_->fps = fps;
  fs::create_directories(impl_->out.parent_path());
}

VideoConcat::~VideoConcat() = default;

Segment VideoConcat::Append(const fs::path& episode_mp4, PixelStats& stats) {
  Impl& m = *impl_;
  if (m.codec == VideoCodec::kCopy) return m.Copy(episode_mp4, stats);
  // kH264, kAv1: decode every frame (RGB) and encode it into the joined file.
  const VideoInfo probe = ProbeVideo(episode_mp4);
  if (std::abs(probe.fps - m.fps) > 0.01) {
    throw Error("frame rate " + Num(probe.fps) + " is not the dataset's " + Num(m.fps),
                episode_mp4.string());
  }
  const std::vector<bool> take = StatsSample(probe.frames);
  ProbeVideo(episode_mp4, [&](const VideoFrame& f) {
    if (static_cast<size_t>(f.index) < take.size() && take[static_cast<size_t>(f.index)]) {
      stats.Add(f.rgb, f.width, f.height, 3 * f.width);
    }
    if (m.width == 0) {
      if (m.codec == VideoCodec::kAv1) {
        m.av1 = std::make_unique<Av1Writer>(m.out, f.width, f.height, m.fps);
      } else {
        VideoOptions options;
        options.fps = m.fps;
        m.writer.emplace(m.out, f.width, f.height, options);
      }
      m.width = f.width;
      m.height = f.height;
    } else if (f.width != m.width || f.height != m.height) {
      throw Error("frame size " + std::to_string(f.width) + "x" + std::to_string(f.height) +
                      " differs from the first episode's " + std::to_string(m.width) + "x" +
                      std::to_string(m.height),
                  episode_mp4.string());
    }
    if (m.av1) {
      m.av1->AddFrame(f.rgb);
    } else {
      m.writer->AddFrame(f.rgb);
    }
  });
  Segment seg;
  seg.from_s = static_cast<double>(m.frames) / m.fps;
  m.frames += probe.frames;
  seg.to_s = static_cast<double>(m.frames) / m.fps;
  seg.frames = probe.frames;
  return seg;
}

void VideoConcat::Finish() {
  Impl& m = *impl_;
  if (m.writer) {
    m.writer->Finish();
    return;
  }
  if (m.av1) {
    m.av1->Finish();
    return;
  }
  if (m.mux == nullptr) throw Error("no episode was added", m.out.string());
  int ret = av_write_trailer(m.mux);
  if (ret < 0) throw Error("cannot finish the MP4: " + AvError(ret), m.out.string());
  if ((ret = avio_closep(&m.mux->pb)) < 0) {
    throw Error("cannot close the file: " + AvError(ret), m.out.string());
  }
}

int VideoConcat::width() const { return impl_->width; }
int VideoConcat::height() const { return impl_->height; }

}  // namespace mlspaces::datagen::lerobot
